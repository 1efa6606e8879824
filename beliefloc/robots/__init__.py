"""The robot side: what a robot reads and did, turned into steps of the belief, and poses back.

* ``localize``: Colledanchise's Algorithm 1 against a robot (act, perceive, update, replan);
  ``line_protocol``: the JSON-lines protocol a real robot speaks (docs/localize-protocol.md);
* ``readings``: raw readings (ranges in metres, classes seen) binned into the map's observations;
* ``tracking``: Markov localization over a logged sequence of steps (``track``).

The simulated grid robot lives in :mod:`beliefloc.simulation`; a belief as a map-frame pose, which
planners, simulations and robots all report, in :mod:`beliefloc.pose`.
"""
