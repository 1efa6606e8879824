"""The files beliefloc reads and writes, each checked before it is trusted.

* ``model_file``: compiled models (``build -o``), with the hash of the map they came from;
  ``model_sources``: ``MAP|MODEL`` arguments (a map, a model file or a ``.pomdp``) to a Model;
* ``macro_file``: Khalvati & Mackworth's macro tables (``macros build -o``);
* ``belief_file``: beliefs as JSON or YAML (``track --json``, ``--belief FILE``);
* ``results_file``: the JSON-lines results of long sweeps (``simulate --out``, ``summarize``);
* ``npz_archive``: the untrusting ``.npz`` reader the binary files share.

One layer below, in :mod:`beliefloc.source`: reading the hand-written files (maps, domains, belief
files) with line marks, the limits every reader enforces, the kinds of file told apart, and the one
way every output is written (a temporary file renamed into place).
"""
