"""Planning benchmark: Colledanchise et al. 2020, Tables I and II, on generated grid worlds, with
the heuristics compared, the speed targets checked, and a plain transcription of Algorithm 1
(``benchmarks/baseline_algorithm1.py``) timed against ``beliefloc.planning.best_first.plan``.

Run by hand from the repository root (not part of the test suite)::

    python -m benchmarks.planning                   # 10^2, 10^3, 10^4 (100 episodes each) + 10^5 (~25 min)
    python -m benchmarks.planning --quick           # 3 episodes at 10^2 and 10^3 (~30 s)
    python -m benchmarks.planning --episodes 20 --big-episodes 5 --output /tmp/planning.md

Worlds are ``beliefloc generate gridworld --seen-model states`` (the authors' setting of Tables I
and II). Episode ``e`` runs on a fresh world with seed ``SeedSequence([seed, e]).generate_state(1)[0]``
(printed in the results as the "world seed"; the world is ``beliefloc generate gridworld --states N
--seed WORLD_SEED --seen-model states`` and the episode ``beliefloc simulate WORLD --seed WORLD_SEED
--max-steps 500``), from a true start drawn uniformly and the uniform start belief. Every strategy
meets the same world, start and noise (paired trials).

Each part runs in its own subprocess per size (``OPENBLAS_NUM_THREADS=1``), so that its peak
resident memory (``ru_maxrss``) is its own:

1. **episodes**: ``bestfirst``, ``random`` and (budgeted) ``uniform`` -- Tables I and II, the k-th
   plan call's time, and every replan of ``bestfirst`` timed again with an empty closed list;
2. **heuristics**: the first plan from the uniform belief with each heuristic, on the first worlds;
3. **baseline**: the first plan from the uniform belief by ``plan()`` and by the Algorithm 1
   transcription, in the same process, on the same worlds.

The table is printed and written to ``benchmarks/results/planning.md`` (``planning-quick.md`` for
``--quick``). Progress goes to stderr.
"""
