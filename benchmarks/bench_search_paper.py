"""Zhang, Sridharan & Wyatt 2015, Sec. IV-A reproduced on ``domains/home.yaml``: H1 (Fig. 4), H2 (Figs. 5
and 6), H3 (Figs. 7 and 8) and a Table-I-like comparison of the policies, with the paper's statements
beside our figures.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_search_paper.py            # 1,000 paired trials per point (~6 min on 2 cores)
    python benchmarks/bench_search_paper.py --quick    # 40-100 trials per point (~30 s), to search-paper-quick.md
    python benchmarks/bench_search_paper.py --trials-knowledge 300 --trials-kb 500 --trials-meta 500 --jobs 1

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

Significance: Wilcoxon signed-rank tests on paired values (``scipy.stats.wilcoxon``, pairs with a
zero difference dropped). The table is printed and written to ``benchmarks/results/search-paper.md``
(``--quick``: ``search-paper-quick.md``), with PNG figures beside it when matplotlib is installed
(``pip install -e '.[plots]'``); without it the markdown says the plots were skipped. Progress goes
to stderr.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from machine import cpu_name  # benchmarks/machine.py (scripts run from benchmarks/ on sys.path)

from beliefloc.knowledge import load_domain
from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.existence import ExistenceStrategy
from beliefloc.object_search.experiment import (
    Arm,
    ArmOutcome,
    TrialRecord,
    TrialSettings,
    room_hit,
    run_trials,
    trial_world,
    typical_rooms,
)
from beliefloc.object_search.posterior import Detector, Revision, TrustFactor
from beliefloc.object_search.trials import World
from beliefloc.object_search.world import search_space

ROOT = Path(__file__).resolve().parent.parent
DOMAIN = ROOT / "domains" / "home.yaml"
RESULTS = ROOT / "benchmarks" / "results" / "search-paper.md"

KNOWLEDGE = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
NO_LIMIT = 1000.0
"""The paper's "unless otherwise stated, there is no time limit": a search that never passes τ+ stops here."""
H3_LIMITS = (10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 80.0, 100.0, 150.0)
"""The baseline's time limits in Fig. 7."""
BETAS = ((3.0, 1.0), (6.0, 2.0), (30.0, 10.0))
"""Fig. 8: one mean (0.75), three variances; the paper names (6, 2) and (30, 10)."""
NOISY_WORLD = Detector(true_positive=0.8, false_positive=0.2)
"""Fig. 6's world: the robot's model says p_TP = 0.9, p_FP = 0.1 (home.yaml); the world errs twice as often."""
TRUST_GRID = ((0.5, 0.0), (0.25, 0.0), (0.75, 0.0), (0.25, 1.0), (0.5, 1.0), (0.75, 1.0))
"""Trust factors (w, r) of the sensitivity table; the first is the main arm (TrustFactor's defaults)."""
STRICTER_TAU = (0.9, 0.95, 0.99)
"""Fig. 6's control: Eq. 7 (static KB) stopping at a stricter τ+, to compare the arms at equal time."""
CDF_CELLS = (0.0, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0)

STRATEGIES = (ExistenceStrategy.EXPECTATION, ExistenceStrategy.UPPER_BOUND, ExistenceStrategy.SAMPLING)
NONE = ExistenceStrategy.NONE

# What the paper says, quoted or read off its text (the figures themselves are not tabulated).
PAPER_H1 = (
    "without defaults, 100 % knowledge: the correct room; 40 %: top-1 ≈ 0.7, top-2 ≈ 90 %; "
    "defaults improve it, most where knowledge is small"
)
PAPER_H2_P = 1e-24
PAPER_H2_ACCURACY_FULL = 0.96
PAPER_FIG6_WITHIN4 = {"dynamic KB": 0.80, "trust factor": 0.66}
PAPER_FIG6_P = {
    ("dynamic KB", "trust factor"): 3.9e-69,
    ("dynamic KB", "static KB"): 1.3e-9,
    ("static KB", "trust factor"): 2.4e-30,
}
PAPER_FIG7 = {"accuracy": 0.85, "sampling": 67.0, "baseline": 85.0}
PAPER_TABLE1 = {"greedy": (2.96, 1.78, 2.4), "pomdp-only": (1.96, 1.32, 1.6)}
"""Time as a factor of ASP+POMDP's: microwave, humanoid, and "averaged across targets"."""


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------------------------
# running parts in parallel: a trial depends only on the seed and its index, so chunks can be joined


@dataclass(frozen=True)
class Part:
    label: str
    settings: TrialSettings
    arms: tuple[Arm, ...]
    trials: int


_DOMAINS: dict[str, Domain] = {}


def _chunk(path: str, arms: tuple[Arm, ...], settings: TrialSettings, seed: int, first: int, count: int) -> Any:
    domain = _DOMAINS.get(path)
    if domain is None:
        domain = _DOMAINS[path] = load_domain(path)
    return run_trials(domain, arms, trials=count, seed=seed, settings=settings, first=first)


def run_part(part: Part, seed: int, jobs: int, pool: ProcessPoolExecutor | None) -> tuple[list[TrialRecord], float]:
    """All trials of a part, in index order, and the wall-clock seconds they took."""
    started = time.perf_counter()
    size = max(1, min(50, math.ceil(part.trials / (4 * jobs))))
    starts = list(range(0, part.trials, size))
    done: dict[int, list[TrialRecord]] = {}
    if pool is None:
        for first in starts:
            done[first] = _chunk(str(DOMAIN), part.arms, part.settings, seed, first, min(size, part.trials - first))
            _progress(part, sum(len(v) for v in done.values()), started)
    else:
        futures = {
            pool.submit(
                _chunk, str(DOMAIN), part.arms, part.settings, seed, first, min(size, part.trials - first)
            ): first
            for first in starts
        }
        for future in as_completed(futures):
            done[futures[future]] = future.result()
            _progress(part, sum(len(v) for v in done.values()), started)
    records = [record for first in starts for record in done[first]]
    seconds = time.perf_counter() - started
    _say(f"  {part.label}: {part.trials} trials x {len(part.arms)} arms in {seconds:.1f} s")
    return records, seconds


def _progress(part: Part, count: int, started: float) -> None:
    """A line that rewrites itself on a terminal (nothing when stderr is a file)."""
    if sys.stderr.isatty():
        line = f"  {part.label}: {count}/{part.trials} ({time.perf_counter() - started:.0f} s)"
        print("\r" + line, end="", file=sys.stderr, flush=True)
        if count == part.trials:
            print("\r" + " " * len(line) + "\r", end="", file=sys.stderr, flush=True)


def outcomes(records: Sequence[TrialRecord], arm: Arm) -> list[ArmOutcome]:
    """``arm``'s outcome in every record, in trial order."""
    return [next(o for o in r.outcomes if o.arm == arm.name) for r in records]


# ----------------------------------------------------------------------------------------------
# statistics


def paired_p(x: Sequence[float], y: Sequence[float]) -> float | None:
    """Two-sided Wilcoxon signed-rank p on pairs (zero differences dropped); None when every pair ties."""
    from scipy.stats import wilcoxon

    a, b = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if not np.any(a != b):
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(wilcoxon(a, b).pvalue)


def mean(values: Sequence[float]) -> float:
    return statistics.fmean(values) if values else float("nan")


def sd(values: Sequence[float]) -> float:
    return statistics.stdev(values) if len(values) > 1 else float("nan")


def meta_accuracy(outcome: ArmOutcome, present: bool) -> float:
    """H3's accuracy: a time limit is "target not found" (Sec. III-B: "... or a time limit is exceeded
    (i.e., target is not found)"), right when the target is absent; a found cell scores the Gaussian
    fall-off (0 when the target is absent)."""
    if outcome.verdict == "found":
        return outcome.accuracy
    return 0.0 if present else 1.0


def meta_accuracies(mine: Sequence[ArmOutcome], present: Sequence[bool]) -> list[float]:
    return [meta_accuracy(o, p) for o, p in zip(mine, present, strict=True)]


def time_to_reach(curve: Sequence[tuple[float, float]], level: float) -> str:
    """The baseline's mean time at which its accuracy first reaches ``level`` (linear interpolation
    between its time limits; ``curve`` is (time, accuracy) by increasing limit)."""
    for k, (t, a) in enumerate(curve):
        if a >= level:
            if k == 0:
                return f"≤ {t:.1f}"
            t0, a0 = curve[k - 1]
            return f"≈ {t0 + (t - t0) * (level - a0) / (a - a0):.1f}"
    return f"never (at most {max(a for _, a in curve):.3f})"


def _p(value: float | None) -> str:
    return "no difference" if value is None else f"{value:.1e}"


def _f(value: float, digits: int = 1) -> str:
    return "-" if math.isnan(value) else f"{value:.{digits}f}"


def _pct(value: float) -> str:
    return "-" if math.isnan(value) else f"{100 * value:.1f} %"


# ----------------------------------------------------------------------------------------------
# the arms

ASP_LIMITED = Arm("pomdp", NONE)
ASP_UNLIMITED = Arm("pomdp", NONE, time_limit=NO_LIMIT)
ONLY_LIMITED = Arm("pomdp-only", NONE)
ONLY_UNLIMITED = Arm("pomdp-only", NONE, time_limit=NO_LIMIT)
GREEDY_UNLIMITED = Arm("greedy", NONE, time_limit=NO_LIMIT)
STATIC = Arm("pomdp", NONE)
DYNAMIC = Arm("pomdp", NONE, dynamic_kb=True)
TRUST = Arm("pomdp", NONE, Revision.TRUST)
FIG6_ARMS = {"static KB": STATIC, "dynamic KB": DYNAMIC, "trust factor": TRUST}
FIG6_CONTROLS = {
    **{f"static KB, τ+ = {tau:g}": Arm("pomdp", NONE, tau_found=tau) for tau in STRICTER_TAU},
    f"dynamic KB, τ+ = {STRICTER_TAU[-1]:g}": Arm("pomdp", NONE, dynamic_kb=True, tau_found=STRICTER_TAU[-1]),
}
H1_TYPICAL = (0.4, 1.0)
"""Knowledge levels of H1 re-run with every object in its default room (p_typical = 1), without defaults."""


def trust_arm(weight: float, r: float) -> Arm:
    if (weight, r) == TRUST_GRID[0]:
        return TRUST
    return Arm("pomdp", NONE, Revision.TRUST, trust=TrustFactor(weight, r))


def baseline_arm(limit: float) -> Arm:
    return Arm("pomdp", NONE, time_limit=limit)


def fig7_arm(strategy: ExistenceStrategy) -> Arm:
    return Arm("pomdp", strategy, time_limit=NO_LIMIT, tau_absent=0.7)


def fig8_arm(strategy: ExistenceStrategy, beta: tuple[float, float]) -> Arm:
    return Arm("pomdp", strategy, time_limit=NO_LIMIT, tau_absent=0.85, alpha=beta[0], beta=beta[1])


def knowledge_parts(trials: int) -> list[Part]:
    parts = []
    for defaults in (False, True):
        for level in KNOWLEDGE:
            arms = [ASP_LIMITED, ASP_UNLIMITED]
            if level == 0.0 and not defaults:
                arms += [ONLY_LIMITED, ONLY_UNLIMITED]
            if level == 0.4 and defaults:
                arms += [GREEDY_UNLIMITED]
            label = f"knowledge {100 * level:.0f} % {'with' if defaults else 'without'} defaults"
            parts.append(Part(label, TrialSettings(knowledge=level, defaults=defaults), tuple(arms), trials))
    return parts


def typical_parts(trials: int) -> list[Part]:
    """H1 with every object in its default room: only the prior is read, one cheap arm runs."""
    return [
        Part(
            f"knowledge {100 * level:.0f} % without defaults, objects in their default rooms",
            TrialSettings(knowledge=level, defaults=False, p_typical=1.0),
            (ASP_LIMITED,),
            trials,
        )
        for level in H1_TYPICAL
    ]


def kb_parts(trials: int) -> list[Part]:
    noisy = TrialSettings(knowledge=0.2, defaults=False, world_detector=NOISY_WORLD)
    arms = (STATIC, DYNAMIC, *(trust_arm(w, r) for w, r in TRUST_GRID), *FIG6_CONTROLS.values())
    matched = TrialSettings(knowledge=0.2, defaults=False)
    return [
        Part("Fig. 6, noisier world", noisy, arms, trials),
        Part("Fig. 6, the model's noise", matched, (STATIC, DYNAMIC, TRUST), trials),
    ]


def meta_part(trials: int) -> Part:
    arms = [baseline_arm(limit) for limit in H3_LIMITS]
    arms += [fig7_arm(s) for s in STRATEGIES]
    arms += [fig8_arm(s, b) for s in STRATEGIES for b in BETAS]
    return Part("Figs. 7-8, target absent in half", TrialSettings(absent_fraction=0.5), tuple(arms), trials)


# ----------------------------------------------------------------------------------------------
# the sections


@dataclass
class Report:
    lines: list[str] = field(default_factory=list)
    plots: dict[str, Callable[[Any], None]] = field(default_factory=dict)
    """Figure name -> a function drawing it on a matplotlib Axes (or a Figure, for two axes)."""

    def add(self, *lines: str) -> None:
        self.lines.extend(lines)


def h1_section(
    report: Report,
    runs: dict[tuple[float, bool], list[TrialRecord]],
    typical_runs: dict[float, list[TrialRecord]],
    rooms: tuple[str, ...],
) -> None:
    def hits(records: list[TrialRecord], k: int) -> float:
        return mean([room_hit(r.room_prior, rooms.index(r.true_room or ""), k) for r in records])

    table = {(level, defaults, k): hits(records, k) for (level, defaults), records in runs.items() for k in (1, 2)}
    n = len(next(iter(runs.values())))
    report.add(
        "## H1: ASP alone (Fig. 4)",
        "",
        f"> **Paper:** {PAPER_H1}.",
        "",
        f"The knowledge base's room prior for the target's class (Eq. 2-5) against the target's true room, {n} "
        "trials per point (targets drawn among all 50 objects). A room is a hit when the prior ranks it first "
        "(top-1) or among the first two (top-2); rooms tied with the true one share the rank at random "
        "(`experiment.room_hit`: a prior that says nothing scores 1/4 and 2/4, not whatever `argmax` would pick).",
        "",
        "| knowledge | top-1 without defaults | top-2 without defaults | top-1 with defaults | top-2 with defaults |",
        "| ---: | ---: | ---: | ---: | ---: |",
    )
    for level in KNOWLEDGE:
        report.add(
            f"| {100 * level:.0f} % | "
            + " | ".join(f"{table[level, d, k]:.3f}" for d in (False, True) for k in (1, 2))
            + " |"
        )
    report.add(
        "",
        f"Paper beside ours: top-1 without defaults at 40 % ≈ 0.7 → **{table[0.4, False, 1]:.3f}**; top-2 at 40 % "
        f"≈ 0.9 → **{table[0.4, False, 2]:.3f}** (with defaults {table[0.4, True, 2]:.3f}); 100 % knowledge → the "
        f"correct room → **{table[1.0, False, 1]:.3f}** without defaults. Defaults raise top-1 at 0 % from "
        f"{table[0.0, False, 1]:.3f} to {table[0.0, True, 1]:.3f} and at 40 % from {table[0.4, False, 1]:.3f} to "
        f"{table[0.4, True, 1]:.3f}.",
        "",
        "The world puts an object with a default in its default room with probability 0.8 only, so even full "
        "knowledge of the other objects cannot always name the target's room. Worlds in which every object with a "
        "default is in its default room (`p_typical = 1`; the same targets, other rooms for the objects), without "
        f"defaults ({len(next(iter(typical_runs.values())))} trials):",
        "",
        "| knowledge | top-1 | top-2 |",
        "| ---: | ---: | ---: |",
        *(
            f"| {100 * level:.0f} % | {hits(records, 1):.3f} | {hits(records, 2):.3f} |"
            for level, records in typical_runs.items()
        ),
        "",
    )

    def draw(ax: Any) -> None:
        x = [100 * level for level in KNOWLEDGE]
        for defaults, style in ((False, "-"), (True, "--")):
            for k, marker in ((1, "o"), (2, "s")):
                label = f"top-{k}, {'with' if defaults else 'without'} defaults"
                ax.plot(x, [table[lv, defaults, k] for lv in KNOWLEDGE], style, marker=marker, label=label)
        ax.plot([40, 40, 100], [0.7, 0.9, 1.0], "k*", markersize=12, label="paper (read from the text)")
        ax.set(xlabel="domain knowledge (%)", ylabel="room accuracy", title="H1: ASP alone (Fig. 4)", ylim=(0, 1.05))
        ax.legend(fontsize=8)

    report.plots["h1"] = draw


def h2_knowledge_section(
    report: Report, runs: dict[tuple[float, bool], list[TrialRecord]], only: dict[int, tuple[ArmOutcome, ArmOutcome]]
) -> None:
    """Fig. 5: time (τ+ only) and accuracy (limit 100) of ASP+POMDP vs POMDP only, paired."""
    n = len(next(iter(runs.values())))
    rows: dict[tuple[float, bool], dict[str, float | None]] = {}
    for (level, defaults), records in runs.items():
        asp_t = [o.time for o in outcomes(records, ASP_UNLIMITED)]
        asp_a = [o.accuracy for o in outcomes(records, ASP_LIMITED)]
        only_t = [only[r.index][1].time for r in records]
        only_a = [only[r.index][0].accuracy for r in records]
        rows[level, defaults] = {
            "asp_t": mean(asp_t),
            "asp_sd": sd(asp_t),
            "only_t": mean(only_t),
            "only_sd": sd(only_t),
            "p_t": paired_p(asp_t, only_t),
            "asp_a": mean(asp_a),
            "only_a": mean(only_a),
            "p_a": paired_p(asp_a, only_a),
            "found": mean([o.verdict == "found" for o in outcomes(records, ASP_LIMITED)]),
        }
    report.add(
        "## H2: ASP + POMDP against POMDP only (Fig. 5)",
        "",
        "> **Paper:** the proposed architecture increases localisation accuracy and reduces localisation time "
        "against POMDPs alone (0 % knowledge = POMDP only); with all other objects' rooms known, accuracy 0.96; "
        f"paired trials at 40 % knowledge: the time improvement has p < {PAPER_H2_P:.0e} over 1,000 trials.",
        "",
        f"{n} paired trials per row, target present. *Time*: until a cell passes τ+ = 0.8 (no time limit; "
        f"{NO_LIMIT:.0f} units as a guard). *Accuracy*: the reported cell's Gaussian fall-off (σ = 2 cells) when "
        "a cell passes τ+ or at 100 time units, whichever comes first. POMDP only (uniform prior over cells) runs "
        "once on the same trials: its rows are the same at every knowledge level. p: Wilcoxon signed-rank, paired.",
        "",
    )
    for defaults in (False, True):
        report.add(
            f"**{'With' if defaults else 'Without'} defaults**",
            "",
            "| knowledge | ASP+POMDP time | POMDP only time | p (time) | ASP+POMDP accuracy | POMDP only accuracy "
            "| p (accuracy) | ASP+POMDP found by 100 |",
            "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
        )
        for level in KNOWLEDGE:
            row = rows[level, defaults]
            report.add(
                f"| {100 * level:.0f} % | {row['asp_t']:.1f} ± {row['asp_sd']:.1f} | "
                f"{row['only_t']:.1f} ± {row['only_sd']:.1f} | {_p(row['p_t'])} | {row['asp_a']:.3f} | "
                f"{row['only_a']:.3f} | {_p(row['p_a'])} | {_pct(row['found'] or 0.0)} |"
            )
        report.add("")
    at40 = rows[0.4, False]
    report.add(
        f"Paper beside ours: at 40 % knowledge (no defaults) ASP+POMDP takes {at40['asp_t']:.1f} time units against "
        f"{at40['only_t']:.1f} for POMDP only, p = {_p(at40['p_t'])} (paper: p < {PAPER_H2_P:.0e}); accuracy at 100 % "
        f"knowledge {rows[1.0, False]['asp_a']:.3f} without defaults, {rows[1.0, True]['asp_a']:.3f} with "
        f"(paper: {PAPER_H2_ACCURACY_FULL}).",
        "",
    )

    def draw(fig: Any) -> None:
        ax_t = fig.add_subplot(1, 2, 1)
        ax_a = fig.add_subplot(1, 2, 2)
        x = [100 * level for level in KNOWLEDGE]
        for defaults, style in ((False, "-"), (True, "--")):
            what = "with" if defaults else "without"
            ax_t.plot(
                x,
                [rows[lv, defaults]["asp_t"] for lv in KNOWLEDGE],
                style,
                marker="^",
                label=f"ASP+POMDP, {what} defaults",
            )
            ax_a.plot(
                x,
                [rows[lv, defaults]["asp_a"] for lv in KNOWLEDGE],
                style,
                marker="*",
                label=f"ASP+POMDP, {what} defaults",
            )
        ax_t.axhline(rows[0.0, False]["only_t"], color="grey", linestyle=":", label="POMDP only")
        ax_a.axhline(rows[0.0, False]["only_a"], color="grey", linestyle=":", label="POMDP only")
        ax_a.plot([100], [PAPER_H2_ACCURACY_FULL], "k*", markersize=12, label="paper: 0.96 at 100 %")
        ax_t.set(xlabel="domain knowledge (%)", ylabel="localisation time (τ+ only)", title="Fig. 5: time")
        ax_t.set_ylim(bottom=0)
        ax_a.set(xlabel="domain knowledge (%)", ylabel="accuracy (time limit 100)", title="Fig. 5: accuracy")
        ax_t.legend(fontsize=8)
        ax_a.legend(fontsize=8)

    report.plots["h2-knowledge"] = draw


def table1_section(report: Report, records: list[TrialRecord], only: dict[int, tuple[ArmOutcome, ArmOutcome]]) -> None:
    asp = outcomes(records, ASP_UNLIMITED)
    policies = {
        "greedy": outcomes(records, GREEDY_UNLIMITED),
        "pomdp-only": [only[r.index][1] for r in records],
        "pomdp (ASP+POMDP)": asp,
    }
    asp_t = [o.time for o in asp]
    report.add(
        "## Table I: the greedy heuristic, POMDP only and ASP+POMDP",
        "",
        "> **Paper** (physical robot, 50 trials, time as a factor of ASP+POMDP's): heuristic 2.96 (microwave), "
        "1.78 (humanoid), ≈ 2.4 averaged over targets; POMDP only 1.96, 1.32, ≈ 1.6; every trial localised the "
        "target; p ∈ [0.008, 0.03] for POMDP only against ASP+POMDP.",
        "",
        f"{len(records)} paired simulated trials, 40 % knowledge with defaults, target present, no time limit "
        f"({NO_LIMIT:.0f} as a guard). `greedy`: the view that would most raise the most likely cell's belief, "
        "were the target there (policy.py).",
        "",
        "| policy | mean time | × ASP+POMDP (ratio of means) | median of per-trial ratios | found | accuracy "
        "| p (time vs ASP+POMDP) | paper × (microwave, humanoid, average) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
    )
    for name, mine in policies.items():
        times = [o.time for o in mine]
        ratio = statistics.median(t / a for t, a in zip(times, asp_t, strict=True))
        paper = PAPER_TABLE1.get(name.split(" ")[0])
        report.add(
            f"| {name} | {mean(times):.1f} | {mean(times) / mean(asp_t):.2f} | {ratio:.2f} | "
            f"{_pct(mean([o.verdict == 'found' for o in mine]))} | {mean([o.accuracy for o in mine]):.3f} | "
            f"{'-' if mine is asp else _p(paired_p(times, asp_t))} | "
            f"{'1' if paper is None else ', '.join(f'{v:g}' for v in paper)} |"
        )
    report.add("")


def commits_right(records: list[TrialRecord], arm: Arm, worlds: dict[int, World]) -> str:
    """The fraction of ``arm``'s commits that put an object in its true room."""
    facts = [
        (r.index, obj, room) for r, o in zip(records, outcomes(records, arm), strict=True) for obj, room in o.commits
    ]
    if not facts:
        return "-"
    return _pct(mean([worlds[index].rooms[obj] == room for index, obj, room in facts]))


def fig6_section(
    report: Report, noisy: list[TrialRecord], matched: list[TrialRecord], worlds: dict[str, dict[int, World]]
) -> None:
    errors = {name: [o.error_cells or 0.0 for o in outcomes(noisy, arm)] for name, arm in FIG6_ARMS.items()}
    within4 = {name: mean([e <= 4.0 for e in errs]) for name, errs in errors.items()}
    report.add(
        "## H2: generating the posterior, and revising the KB (Fig. 6)",
        "",
        "> **Paper:** 20 % knowledge, no defaults, a trial ends when a cell passes 0.8 or at 100 time units, extra "
        "noise on the observations. With the dynamic KB ≈ 80 % of the trials have a localisation error ≤ 4 cells, "
        "with trust factors 66 %; even the static KB beats trust factors. Paired p-values: dynamic vs trust "
        "3.9e-69, dynamic vs static 1.3e-9, static vs trust 2.4e-30.",
        "",
        f"{len(noisy)} paired trials: 20 % knowledge, no defaults, time limit 100, the world's detector at "
        f"p_TP = {NOISY_WORLD.true_positive}, p_FP = {NOISY_WORLD.false_positive} while the robot's model says 0.9, "
        "0.1 (our reading of the extra noise). *Static KB*: Eq. 7 with the 20 % prior. *Dynamic KB*: objects seen "
        "with room belief > 0.9 are committed, the KB solved again and its prior combined with the kept likelihood "
        "(observation re-use). *Trust factor*: b ∝ b_kb^w · b_pomdp^(1-w) with w = 0.5, r = 0 (TrustFactor's "
        "defaults, not tuned; the paper gives neither). Error: the distance in cells between the reported cell "
        "and the true one (at the time limit, the most likely cell is reported).",
        "",
        "| arm | "
        + " | ".join(f"≤ {c:g}" for c in CDF_CELLS)
        + " | mean error | mean time | found | commits | commits right |",
        "| --- | " + " | ".join("---:" for _ in CDF_CELLS) + " | ---: | ---: | ---: | ---: | ---: |",
    )
    for name, arm in {**FIG6_ARMS, **FIG6_CONTROLS}.items():
        mine = outcomes(noisy, arm)
        errs = [o.error_cells or 0.0 for o in mine]
        report.add(
            f"| {name} | "
            + " | ".join(f"{mean([e <= c for e in errs]):.3f}" for c in CDF_CELLS)
            + f" | {mean(errs):.2f} | {mean([o.time for o in mine]):.1f} | "
            f"{_pct(mean([o.verdict == 'found' for o in mine]))} | {mean([len(o.commits) for o in mine]):.1f} | "
            f"{commits_right(noisy, arm, worlds['noisy'])} |"
        )
    report.add(
        "",
        "The rows below the first three are controls, not in the paper: Eq. 7 stopping at a stricter τ+, to "
        "compare the arms at equal time.",
        "",
        "Within 4 cells, paper beside ours: "
        + "; ".join(f"{name} {PAPER_FIG6_WITHIN4[name]:.0%} → **{within4[name]:.1%}**" for name in PAPER_FIG6_WITHIN4)
        + f"; static KB (paper: between the two) → **{within4['static KB']:.1%}**.",
        "",
        "| paired test on the error (Wilcoxon) | ours | paper | mean error, first vs second |",
        "| --- | ---: | ---: | --- |",
    )
    for (a, b), paper in PAPER_FIG6_P.items():
        report.add(
            f"| {a} vs {b} | {_p(paired_p(errors[a], errors[b]))} | {paper:.1e} | "
            f"{mean(errors[a]):.2f} vs {mean(errors[b]):.2f} |"
        )
    report.add(
        "",
        "**Trust factors' sensitivity** (same trials; w: trust in the KB's belief, r: the r-norm's exponent, "
        "0 logarithmic, 1 linear):",
        "",
        "| w | r | ≤ 4 cells | mean error | mean time | found |",
        "| ---: | ---: | ---: | ---: | ---: | ---: |",
    )
    for weight, r in TRUST_GRID:
        mine = outcomes(noisy, trust_arm(weight, r))
        errs = [o.error_cells or 0.0 for o in mine]
        report.add(
            f"| {weight:g} | {r:g} | {mean([e <= 4 for e in errs]):.3f} | {mean(errs):.2f} | "
            f"{mean([o.time for o in mine]):.1f} | {_pct(mean([o.verdict == 'found' for o in mine]))} |"
        )
    report.add(
        "",
        f"**With the model's own noise** (the world detects at 0.9 / 0.1; {len(matched)} paired trials):",
        "",
        "| arm | ≤ 4 cells | ≤ 0 cells | mean error | mean time | found | commits right |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    )
    for name, arm in FIG6_ARMS.items():
        mine = outcomes(matched, arm)
        errs = [o.error_cells or 0.0 for o in mine]
        report.add(
            f"| {name} | {mean([e <= 4 for e in errs]):.3f} | {mean([e == 0 for e in errs]):.3f} | {mean(errs):.2f} | "
            f"{mean([o.time for o in mine]):.1f} | {_pct(mean([o.verdict == 'found' for o in mine]))} | "
            f"{commits_right(matched, arm, worlds['matched'])} |"
        )
    report.add("")

    def draw(ax: Any) -> None:
        grid = np.linspace(0, 12, 241)
        for name, errs in errors.items():
            values = np.asarray(errs)
            ax.plot(grid, [(values <= g).mean() for g in grid], label=name)
        ax.plot(
            [4, 4],
            [PAPER_FIG6_WITHIN4["dynamic KB"], PAPER_FIG6_WITHIN4["trust factor"]],
            "k*",
            markersize=12,
            label="paper at 4 cells: dynamic 80 %, trust 66 %",
        )
        ax.set(
            xlabel="localisation error (cells)",
            ylabel="fraction of trials with error ≤ x",
            title="Fig. 6: CDF of the localisation error",
            ylim=(0, 1.02),
        )
        ax.legend(fontsize=8, loc="lower right")

    report.plots["h2-cdf"] = draw


def fig7_section(report: Report, records: list[TrialRecord]) -> None:
    present = [r.present for r in records]

    def stats(arm: Arm) -> dict[str, float]:
        mine = outcomes(records, arm)
        acc = [meta_accuracy(o, p) for o, p in zip(mine, present, strict=True)]
        return {
            "time": mean([o.time for o in mine]),
            "acc": mean(acc),
            "acc_present": mean([a for a, p in zip(acc, present, strict=True) if p]),
            "acc_absent": mean([a for a, p in zip(acc, present, strict=True) if not p]),
            "acc_cell": mean([o.accuracy for o in mine]),
            "found": mean([o.verdict == "found" for o in mine]),
            "not_found": mean([o.verdict == "not-found" for o in mine]),
            "time_limit": mean([o.verdict == "time-limit" for o in mine]),
        }

    baseline = {limit: stats(baseline_arm(limit)) for limit in H3_LIMITS}
    strategies = {s: stats(fig7_arm(s)) for s in STRATEGIES}
    curve = [(baseline[limit]["time"], baseline[limit]["acc"]) for limit in H3_LIMITS]
    report.add(
        "## H3: metareasoning against the baseline (Fig. 7)",
        "",
        "> **Paper:** τ- = 0.7, target absent in half of the trials (unknown to the robot), static KB. The baseline "
        "stops at τ+ or its time limit and localises more accurately given more time; the three strategies stop "
        "early when p(¬E) > τ- and take significantly less time. For accuracy 0.85, sampling takes ≈ 67 time units, "
        "the baseline ≈ 85. Expectation: the least time and the lowest accuracy; upper bound: the most time and "
        "the highest accuracy; sampling in between.",
        "",
        f"{len(records)} paired trials ({sum(not p for p in present)} with the target absent), 40 % knowledge with "
        "defaults, Beta (6, 2). The baseline at each time limit; the strategies with no time limit "
        f'({NO_LIMIT:.0f} as a guard). *Accuracy* as the paper counts it: a time limit means "not found" (Sec. '
        "III-B), right when the target is absent; Not found when it is present scores 0; a found cell scores the "
        "Gaussian fall-off, 0 when the target is absent. The last column scores a time limit by the cell it "
        "would report instead.",
        "",
        "| arm | mean time | accuracy | present | absent | found | not found | time limit | accuracy (time "
        "limit reports a cell) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    )
    rows = [(f"baseline, limit {limit:g}", baseline[limit]) for limit in H3_LIMITS]
    rows += [(s.value, strategies[s]) for s in STRATEGIES]
    for name, row in rows:
        report.add(
            f"| {name} | {row['time']:.1f} | {row['acc']:.3f} | {row['acc_present']:.3f} | {row['acc_absent']:.3f} | "
            f"{_pct(row['found'])} | {_pct(row['not_found'])} | {_pct(row['time_limit'])} | {row['acc_cell']:.3f} |"
        )
    base100 = outcomes(records, baseline_arm(100.0))
    report.add(
        "",
        "| strategy | its time | its accuracy | baseline's time for that accuracy (interpolated) | p (time vs "
        "baseline, limit 100) | p (accuracy vs baseline, limit 100) |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    )
    for s in STRATEGIES:
        mine = outcomes(records, fig7_arm(s))
        report.add(
            f"| {s.value} | {strategies[s]['time']:.1f} | {strategies[s]['acc']:.3f} | "
            f"{time_to_reach(curve, strategies[s]['acc'])} | "
            f"{_p(paired_p([o.time for o in mine], [o.time for o in base100]))} | "
            f"{_p(paired_p(meta_accuracies(mine, present), meta_accuracies(base100, present)))} |"
        )
    report.add(
        "",
        f"Paper beside ours: accuracy {PAPER_FIG7['accuracy']} takes ≈ {PAPER_FIG7['sampling']:.0f} (sampling) vs "
        f"≈ {PAPER_FIG7['baseline']:.0f} (baseline); here the baseline reaches {PAPER_FIG7['accuracy']} at "
        f"{time_to_reach(curve, PAPER_FIG7['accuracy'])} time units, and sampling reaches "
        f"{strategies[ExistenceStrategy.SAMPLING]['acc']:.3f} at {strategies[ExistenceStrategy.SAMPLING]['time']:.1f}.",
        "",
    )

    def draw(ax: Any) -> None:
        ax.plot([t for t, _ in curve], [a for _, a in curve], "k-+", markersize=10, label="baseline (time limits)")
        for limit, (t, a) in zip(H3_LIMITS, curve, strict=True):
            ax.annotate(f"{limit:g}", (t, a), textcoords="offset points", xytext=(3, -10), fontsize=7)
        for s, marker in zip(STRATEGIES, ("o", "s", "D"), strict=True):
            ax.plot(strategies[s]["time"], strategies[s]["acc"], marker, markersize=9, label=s.value)
        ax.plot(
            [PAPER_FIG7["sampling"], PAPER_FIG7["baseline"]],
            [PAPER_FIG7["accuracy"]] * 2,
            "k*",
            markersize=12,
            label="paper: sampling 67, baseline 85 at 0.85",
        )
        ax.set(
            xlabel="mean localisation time",
            ylabel="accuracy (time limit = not found)",
            title="Fig. 7: time against accuracy, τ- = 0.7, half absent",
        )
        ax.legend(fontsize=8, loc="lower right")

    report.plots["h3-time-accuracy"] = draw


def fig8_section(report: Report, records: list[TrialRecord]) -> None:
    present = [r.present for r in records]
    times = {(s, b): [o.time for o in outcomes(records, fig8_arm(s, b))] for s in STRATEGIES for b in BETAS}
    report.add(
        "## H3: the Beta prior's variance (Fig. 8)",
        "",
        "> **Paper:** τ- = 0.85, target absent in half of the trials. (6, 2) and (30, 10) have the same mean; the "
        "expectation strategy does not change, upper bound and sampling take less time with the lower variance; "
        "both approach the expectation strategy in the limit of infinite historical data.",
        "",
        f"The same {len(records)} trials as Fig. 7, no time limit; (3, 1) added as a third set of the same mean. "
        "Mean localisation time ± standard deviation (all trials; in brackets, the absent-target trials only) "
        "and the accuracy (as in Fig. 7).",
        "",
        "| strategy | " + " | ".join(f"({a:g}, {b:g})" for a, b in BETAS) + " | p, (6, 2) vs (30, 10) |",
        "| --- | " + " | ".join("---:" for _ in BETAS) + " | ---: |",
    )
    for s in STRATEGIES:
        cells = []
        for b in BETAS:
            mine = outcomes(records, fig8_arm(s, b))
            absent = [o.time for o, p in zip(mine, present, strict=True) if not p]
            acc = mean([meta_accuracy(o, p) for o, p in zip(mine, present, strict=True)])
            cells.append(f"{mean(times[s, b]):.1f} ± {sd(times[s, b]):.1f} ({mean(absent):.1f}), acc {acc:.3f}")
        report.add(
            f"| {s.value} | " + " | ".join(cells) + f" | {_p(paired_p(times[s, BETAS[1]], times[s, BETAS[2]]))} |"
        )
    report.add("")

    def draw(ax: Any) -> None:
        width = 0.25
        for k, b in enumerate(BETAS):
            xs = [i + (k - 1) * width for i in range(len(STRATEGIES))]
            ys = [mean(times[s, b]) for s in STRATEGIES]
            err = [sd(times[s, b]) / math.sqrt(len(times[s, b])) for s in STRATEGIES]
            ax.bar(xs, ys, width, yerr=err, capsize=3, label=f"Beta({b[0]:g}, {b[1]:g})")
        ax.set_xticks(range(len(STRATEGIES)), [s.value for s in STRATEGIES])
        ax.set(ylabel="mean localisation time (± s.e.)", title="Fig. 8: one mean, three variances, τ- = 0.85")
        ax.legend(fontsize=8)

    report.plots["h3-beta"] = draw


# ----------------------------------------------------------------------------------------------


def write_plots(report: Report, output: Path) -> list[Path] | None:
    """PNG figures beside ``output`` (``<stem>-<name>.png``); None when matplotlib is not installed."""
    try:
        import matplotlib
    except ImportError:
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    for name, draw in report.plots.items():
        two = name == "h2-knowledge"
        fig = plt.figure(figsize=(11 if two else 6.5, 4.5))
        if two:
            draw(fig)
        else:
            draw(fig.add_subplot(1, 1, 1))
        fig.tight_layout()
        path = output.with_name(f"{output.stem}-{name}.png")
        fig.savefig(path, dpi=110, metadata={"Software": None})
        plt.close(fig)
        written.append(path)
    return written


def _versions() -> str:
    import clingo
    import scipy

    python = platform.python_version()
    return f"Python {python}, numpy {np.__version__}, scipy {scipy.__version__}, clingo {clingo.__version__}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument(
        "--quick", action="store_true", help="40-100 trials per point (~30 s), to search-paper-quick.md"
    )
    parser.add_argument(
        "--trials-knowledge", type=int, default=None, help="H1, Fig. 5, Table I (default 1000, quick 40)"
    )
    parser.add_argument("--trials-kb", type=int, default=None, help="Fig. 6 (default 1000, quick 100)")
    parser.add_argument("--trials-meta", type=int, default=None, help="Figs. 7 and 8 (default 1000, quick 100)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes (default: the cores)")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    n_knowledge = args.trials_knowledge or (40 if args.quick else 1000)
    n_kb = args.trials_kb or (100 if args.quick else 1000)
    n_meta = args.trials_meta or (100 if args.quick else 1000)
    if min(n_knowledge, n_kb, n_meta) < 2 or args.jobs < 1:
        parser.error("need at least 2 trials per part and 1 job")
    output: Path = args.output or (RESULTS.with_name("search-paper-quick.md") if args.quick else RESULTS)
    output.parent.mkdir(parents=True, exist_ok=True)
    began = time.perf_counter()
    domain = load_domain(DOMAIN)
    space = search_space(domain)
    timings: dict[str, float] = {}
    pool = ProcessPoolExecutor(args.jobs) if args.jobs > 1 else None
    try:
        _say(f"knowledge: {len(KNOWLEDGE) * 2} parts x {n_knowledge} trials")
        knowledge: dict[tuple[float, bool], list[TrialRecord]] = {}
        for part in knowledge_parts(n_knowledge):
            knowledge[part.settings.knowledge, part.settings.defaults], seconds = run_part(
                part, args.seed, args.jobs, pool
            )
            timings["H1, Fig. 5, Table I"] = timings.get("H1, Fig. 5, Table I", 0.0) + seconds
        typical: dict[float, list[TrialRecord]] = {}
        for part in typical_parts(n_knowledge):
            typical[part.settings.knowledge], seconds = run_part(part, args.seed, args.jobs, pool)
            timings["H1 in default rooms"] = timings.get("H1 in default rooms", 0.0) + seconds
        _say(f"kb: 2 parts x {n_kb} trials")
        (noisy_part, matched_part) = kb_parts(n_kb)
        (noisy, s1), (matched, s2) = (run_part(p, args.seed, args.jobs, pool) for p in (noisy_part, matched_part))
        timings["Fig. 6"] = s1 + s2
        _say(f"meta: {n_meta} trials")
        meta, timings["Figs. 7-8"] = run_part(meta_part(n_meta), args.seed, args.jobs, pool)
    finally:
        if pool is not None:
            pool.shutdown()

    # POMDP only ran in the (0 %, no defaults) part; every part has the same worlds and targets
    only_records = knowledge[0.0, False]
    only = {
        r.index: (
            next(o for o in r.outcomes if o.arm == ONLY_LIMITED.name),
            next(o for o in r.outcomes if o.arm == ONLY_UNLIMITED.name),
        )
        for r in only_records
    }
    for records in knowledge.values():
        for r, base in zip(records, only_records, strict=True):
            assert (r.index, r.target, r.true_cell) == (base.index, base.target, base.true_cell), "parts not paired"

    report = Report()
    command = " ".join(sys.argv[1:] if argv is None else argv)
    total = time.perf_counter() - began
    report.add(
        "# Object search: Zhang, Sridharan & Wyatt 2015, Sec. IV-A, reproduced",
        "",
        f"`python benchmarks/bench_search_paper.py {command}`".replace(" `", "`"),
        "",
        f"Machine: {platform.machine()} ({cpu_name()}), {os.cpu_count()} cores, {_versions()}; {args.jobs} worker "
        f"process(es); seed {args.seed}. {total:.0f} s in all: "
        + ", ".join(f"{label} {seconds:.0f} s" for label, seconds in timings.items())
        + ".",
        "",
        "## The setting, ours beside the paper's",
        "",
        "- **Domain**: `domains/home.yaml` -- bedroom, study, kitchen, living room (the paper's Fig. 2 plus a "
        "living room), 25 cells each, 50 objects in 10 categories, as in Sec. IV-A. Targets: any of the 50 objects, "
        "drawn per trial; the robot never knows the target's room.",
        "- **Ground truth** (`trials.py`): an object with a default is in its default room with probability 0.8, "
        "elsewhere uniformly (our choice: the paper does not say how its simulated objects were placed); each "
        'object on a random cell of its room. "% of domain knowledge" = the fraction of the other objects whose '
        "true room the robot knows.",
        "- **Search** (`loop.py`, `policy.py`): the VS-POMDP is our one-step expected-entropy-reduction per time "
        "unit over 3x3 views (the paper's is a hierarchy of POMDPs with learned visual models); detector "
        "p_TP = 0.9, p_FP = 0.1; 0.5 time units per cell travelled, 1 per view; τ+ = 0.8. Accuracy: a Gaussian "
        "fall-off with σ = 2 cells (the paper gives no σ).",
        f"- **Trials**: {n_knowledge} (H1, Fig. 5, Table I), {n_kb} (Fig. 6) and {n_meta} (Figs. 7-8) paired "
        "trials per point; the paper averages 5,000 per point (1,000 for Fig. 5's test). The paper's H3 knowledge "
        "level is not stated: we use 40 % with defaults (`search simulate`'s default).",
        "",
    )
    typical_room = typical_rooms(domain)
    worlds = {
        name: {
            r.index: trial_world(domain, space, typical_room, index=r.index, seed=args.seed, settings=part.settings)
            for r in records
        }
        for name, part, records in (("noisy", noisy_part, noisy), ("matched", matched_part, matched))
    }
    h1_section(report, knowledge, typical, space.rooms)
    h2_knowledge_section(report, knowledge, only)
    table1_section(report, knowledge[0.4, True], only)
    fig6_section(report, noisy, matched, worlds)
    fig7_section(report, meta)
    fig8_section(report, meta)
    written = write_plots(report, output)
    if written is None:
        report.add("## Figures", "", "Plots skipped: matplotlib is not installed (`pip install -e '.[plots]'`).", "")
    else:
        report.add("## Figures", "")
        report.add(*(f"![{path.stem}]({path.name})" for path in written), "")
    report.add(NOTES)
    text = "\n".join(report.lines).rstrip() + "\n"
    output.write_text(text)
    print(text)
    _say(f"written to {output}" + ("" if written is None else f" and {len(written)} PNG files beside it"))
    return 0


NOTES = """## What the run says

Written from the full run (seed 0, 1,000 paired trials per point); the numbers quoted are those of
the tables above for that run.

- **H1, ASP alone: the trend holds, the levels do not.** Room accuracy grows with knowledge (top-1
  without defaults 0.25 -> 0.71 from 0 % to 100 %) and defaults help most where knowledge is small
  (top-1 0.75 at 0 %), as in Fig. 4; but we stay below the paper (40 %: top-1 0.59 and top-2 0.75
  against ≈ 0.7 and ≈ 0.9; 100 %: 0.71 against the correct room every time). The ceiling is the
  domain, not the knowledge base: `home.yaml` places five objects outside their default room
  (pillow3 and blanket2 in the living room, computer4 and textbook3 in the bedroom, cup3 in the study)
  and magazines have no default, so even with every other object in its default room and every room
  known, top-1 is 0.81. With defaults, more knowledge slightly *lowers* top-1 (0.75 -> 0.73): the
  known objects include the atypical ones, whose counts pull the prior away from the default.
- **H2, Fig. 5: time yes, accuracy no.** The KB prior cuts the time to pass τ+ wherever it says
  anything (0 % without defaults is POMDP only), by 6-26 % (40 % without defaults: 34.0 -> 28.4,
  p = 6e-17; with defaults -> 25.3, p = 1e-37; the paper: p < 1e-24). Accuracy at the 100-unit
  limit does not change (0.96-0.97 for every row, no p below 0.1): about 99 % of our searches pass
  τ+ within 100 units, and what error remains is mostly a neighbour of the target passing τ+ (a view
  covers the neighbours too), which a room prior cannot fix. The paper's accuracy gain comes from
  searches its time limit cut short; ours rarely are. Our accuracy with full knowledge (0.97) is
  close to the paper's 0.96.
- **Table I: the same order, smaller factors.** The greedy heuristic and POMDP only take 1.42x and
  1.34x ASP+POMDP's mean time (medians of the per-trial ratios: 1.19 and 1.40), both p < 1e-36; on
  the paper's robot, ≈ 2.4x and ≈ 1.6x. The greedy policy as first written stood on the most likely
  cell and hit the time limit in about 95 % of the trials; the one now in policy.py localises every
  target.
- **H2, Fig. 6: not reproduced -- the trust factor comes out best.** Within 4 cells: trust factor
  96.3 %, static KB 86.5 %, dynamic KB 83.7 % (the paper: 66 %, in between, ≈ 80 %); the paired tests
  are as significant as the paper's, the other way round for the trust factor. What we measured:
  1. With w = 1/2, r = 0 the pooled belief is exactly Eq. 7's posterior to the power 1/2,
     renormalised (b_kb^1/2 b_ob^1/2 = (b_kb b_ob)^1/2), so passing τ+ = 0.8 needs Eq. 7's posterior
     concentrated on one cell far beyond 0.8: a stricter stopping rule. The trust arm takes 48.9 time
     units against 36.0. Eq. 7 stopping at τ+ = 0.99 closes most of the gap at the same time (94.0 %
     at 49.7 units); the last 2 points may come from tempering an overconfident model (the world errs
     at 0.8 / 0.2, the robot reasons with 0.9 / 0.1). With the model's own noise the three arms are
     within 2 points of each other (98.0 %, 97.8 %, 99.7 %).
  2. The dynamic KB commits what it believes it saw: in the noisier world 26 % of its commits put an
     object in the wrong room (6 % with the model's noise), and a wrong fact misleads the prior. Even
     right commits help little: at 20 % knowledge without defaults the prior changes the time more
     than the error (Fig. 5).
  Linear pooling (r = 1) is the only trust-factor setting below Eq. 7 (47-56 % within 4 cells) --
  nearer the paper's 66 % -- because it can never pass τ+ (TrustFactor's docstring) and every search
  ends at the time limit. We did not choose it: the paper gives neither the weights nor the exponent.
- **H3, Fig. 7: early termination holds, the time-accuracy gain is small.** The three strategies end
  absent-target searches early (30.6, 44.7 and 33.8 time units against 62.0 for the baseline at limit
  100, p < 1e-80) at the baseline's accuracy (no significant difference), in the paper's order:
  expectation fastest and least accurate (0.928), upper bound slowest and most accurate (0.945),
  sampling in between (0.937). Against the baseline's whole curve, expectation and sampling save
  about 12-16 % of the time for the same accuracy (30.6 against ≈ 36.2, 33.8 against ≈ 38.6), upper
  bound nothing (44.7 against ≈ 41.4); the paper: 67 against 85 at accuracy 0.85. Our searches are
  short (a present target passes τ+ in ≈ 25 units), so a baseline cut at 20-30 units already reaches
  0.85 -- giving up at the limit is a cheap "not found" -- and the paper's time scale does not carry
  over. Past 60 units the baseline gains nothing and at 150 loses (0.917): a long enough search for an
  absent target ends up confirming a false positive (p_FP = 0.1).
- **H3, Fig. 8: reproduced.** With one mean (0.75) the expectation strategy's searches are identical
  for (3, 1), (6, 2) and (30, 10); upper bound and sampling take less time as the variance shrinks
  (upper bound 62.3 -> 53.3 -> 45.2, sampling 49.4 -> 44.5 -> 40.8; (6, 2) against (30, 10):
  p < 1e-80), approaching the expectation strategy (39.9), at unchanged accuracy (0.94-0.95).
- **Not modelled**: the paper's hierarchy of visual-processing POMDPs, its learned object models and
  its Gaussian observation noise (replaced by a world detector noisier than the model), its domain's
  object placement, the physical robot of Table I, and 5,000 trials per point."""


if __name__ == "__main__":
    raise SystemExit(main())
