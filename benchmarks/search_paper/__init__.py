"""Zhang, Sridharan & Wyatt 2015, Sec. IV-A reproduced on ``domains/home.yaml``: H1 (Fig. 4), H2 (Figs. 5
and 6), H3 (Figs. 7 and 8) and a Table-I-like comparison of the policies, with the paper's statements
beside our figures.

Run by hand from the repository root (not part of the test suite)::

    python -m benchmarks.search_paper            # 1,000 paired trials per point (~6 min on 2 cores)
    python -m benchmarks.search_paper --quick    # 40-100 trials per point (~30 s), to search-paper-quick.md
    python -m benchmarks.search_paper --trials-knowledge 300 --trials-kb 500 --trials-meta 500 --workers 1

Every part is a set of paired trials (:mod:`beliefloc.object_search.experiment`): trial ``i`` of a run
seeded ``s`` has the same world, target, robot knowledge and detection noise for every arm, and the
same world and target in every part (only the knowledge fraction, the defaults, the absent draw
and the world's noise differ between parts). The parts:

1. **knowledge** (``--trials-knowledge``, 1,000): knowledge 0, 20, ..., 100 %, without and with the
   domain's defaults, target present. The knowledge base's room prior gives H1 (ASP alone: is the
   true room the prior's first, or among its first two?). ASP+POMDP (``pomdp``) runs with the
   domain's time limit (100, for Fig. 5's accuracy) and without one (for its time: "terminated when
   the belief in a specific cell exceeded the threshold"); POMDP only (``pomdp-only``) runs once, on
   the same trials (its prior is uniform whatever the knowledge). At 40 % with defaults the
   ``greedy`` policy runs too, for Table I.
2. **kb** (``--trials-kb``, 1,000): Fig. 6 -- 20 % knowledge, no defaults, time limit 100, a world
   noisier than the robot's model (Sec. IV-A: "some extra noise was added to the observations"):
   static KB, dynamic KB (observation re-use) and the trust-factor merge, and the trust factors'
   sensitivity; then again with the model's own noise.
3. **meta** (``--trials-meta``, 1,000): the target absent in half of the trials, 40 % knowledge with
   defaults, static KB. Fig. 7: the baseline (no metareasoning) at several time limits against the
   three strategies with τ- = 0.7; Fig. 8: the strategies with τ- = 0.85 and Beta priors (3, 1),
   (6, 2), (30, 10) -- one mean, 0.75, three variances.

4. **scene models** (``--trials-scenes``, 1,000; issue 31): H1 in a correlated world (the class-to-room
   ties of the paper's domain, ``--correlation``), from the knowledge base's priors alone, beside the
   old setting; then 40 % knowledge with defaults, target present, with the domain's scene model: the
   SP-POMDP's searches (ASP+POMDP and POMDP only), every operator on every ROI, and the fixed detector;
   the solve time of every kind of view and ``search simulate -n 200`` with and without the scene
   model. ``--only-scenes`` runs only this part and splices its sections into the existing report.
   Every other part keeps the fixed detector (``Part.scenes`` False), as before the scene model.

Significance: Wilcoxon signed-rank tests on paired values (``scipy.stats.wilcoxon``, pairs with a
zero difference dropped). The table is printed and written to ``benchmarks/results/search-paper.md``
(``--quick``: ``search-paper-quick.md``), with PNG figures beside it when matplotlib is installed
(``pip install -e '.[plots]'``); without it the markdown says the plots were skipped. Progress goes
to stderr.
"""
