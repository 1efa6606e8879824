"""Object search (Zhang, Sridharan & Wyatt 2015): a belief over the target's cell from a knowledge-base
prior and kept observation likelihoods, and metareasoning about whether the target exists at all.

One algorithm or role per module:

* ``settings``: the vocabulary (metareasoning, revisions, policy names) and the checks of a search's
  values; no numeric imports, so the command line can offer the names without loading numpy;
* ``space``: the robot's model, the search space (cells, rooms, sparse views) on a plane of rooms;
  ``map_space``: the same on a semantic map; ``domain_space``: ``search_space(domain)``, either one;
* ``world``: the simulated world (where every object is, the target's and the objects' detectors,
  the images of a scene model's views);
* ``scene``: the SP-POMDP (Sec. III-B, Fig. 3) that analyses a view's image with a scene model: the
  exact lower- and higher-level policies and their outcome per kind of view;
  ``scene_views``: the scene model attached to a search space (the rates of every view, cached);
* ``posterior``: Eq. 6-7, the cell belief, its revision (re-use, discard, trust factors);
* ``existence``: Eq. 8-14, the Beta metareasoning and its three approximations;
* ``policy``: which view to analyse next (``pomdp``, ``greedy``, ``pomdp-only``);
* ``dynamic``: Algorithm 1 lines 7-10, objects seen during the search committed to the knowledge base;
* ``loop``: Algorithm 1 itself (``run_search``, ``seeded_search``);
* ``trials``: the random streams of paired trials and the robot's partial knowledge (pure, seeded);
* ``experiment``: paired trials over arms and their summary (``run_trials``, ``summarize``).
"""
