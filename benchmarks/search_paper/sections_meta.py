"""The sections from the meta part (the target absent in half of the trials): H3's Fig. 7
(metareasoning against the baseline's time limits) and Fig. 8 (the Beta prior's variance)."""

from __future__ import annotations

from beliefloc.object_search.experiment import Arm, TrialRecord
from beliefloc.object_search.loop import Verdict
from beliefloc.object_search.settings import Metareasoning
from benchmarks.stats import mean, paired_p, sd

from . import plots
from .paper import PAPER_FIG7
from .report import Report, meta_accuracies, meta_accuracy, p_value, percent, time_to_reach
from .running import outcomes
from .settings import BETAS, H3_LIMITS, METAREASONING, NO_LIMIT, baseline_arm, fig7_arm, fig8_arm


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
            "found": mean([o.verdict is Verdict.FOUND for o in mine]),
            "not_found": mean([o.verdict is Verdict.NOT_FOUND for o in mine]),
            "time_limit": mean([o.verdict is Verdict.TIME_LIMIT for o in mine]),
        }

    baseline = {limit: stats(baseline_arm(limit)) for limit in H3_LIMITS}
    by_metareasoning = {s: stats(fig7_arm(s)) for s in METAREASONING}
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
    rows += [(s.value, by_metareasoning[s]) for s in METAREASONING]
    for name, row in rows:
        report.add(
            f"| {name} | {row['time']:.1f} | {row['acc']:.3f} | {row['acc_present']:.3f} | {row['acc_absent']:.3f} | "
            f"{percent(row['found'])} | {percent(row['not_found'])} | {percent(row['time_limit'])} | "
            f"{row['acc_cell']:.3f} |"
        )
    base100 = outcomes(records, baseline_arm(100.0))
    report.add(
        "",
        "| strategy | its time | its accuracy | baseline's time for that accuracy (interpolated) | p (time vs "
        "baseline, limit 100) | p (accuracy vs baseline, limit 100) |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    )
    for s in METAREASONING:
        mine = outcomes(records, fig7_arm(s))
        report.add(
            f"| {s.value} | {by_metareasoning[s]['time']:.1f} | {by_metareasoning[s]['acc']:.3f} | "
            f"{time_to_reach(curve, by_metareasoning[s]['acc'])} | "
            f"{p_value(paired_p([o.time for o in mine], [o.time for o in base100]))} | "
            f"{p_value(paired_p(meta_accuracies(mine, present), meta_accuracies(base100, present)))} |"
        )
    sampling = by_metareasoning[Metareasoning.SAMPLING]
    report.add(
        "",
        f"Paper beside ours: accuracy {PAPER_FIG7['accuracy']} takes ≈ {PAPER_FIG7['sampling']:.0f} (sampling) vs "
        f"≈ {PAPER_FIG7['baseline']:.0f} (baseline); here the baseline reaches {PAPER_FIG7['accuracy']} at "
        f"{time_to_reach(curve, PAPER_FIG7['accuracy'])} time units, and sampling reaches "
        f"{sampling['acc']:.3f} at {sampling['time']:.1f}.",
        "",
    )

    report.plots["h3-time-accuracy"] = plots.h3_time_accuracy(curve, by_metareasoning)


def fig8_section(report: Report, records: list[TrialRecord]) -> None:
    present = [r.present for r in records]
    times = {(s, b): [o.time for o in outcomes(records, fig8_arm(s, b))] for s in METAREASONING for b in BETAS}
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
    for s in METAREASONING:
        cells = []
        for b in BETAS:
            mine = outcomes(records, fig8_arm(s, b))
            absent = [o.time for o, p in zip(mine, present, strict=True) if not p]
            acc = mean([meta_accuracy(o, p) for o, p in zip(mine, present, strict=True)])
            cells.append(f"{mean(times[s, b]):.1f} ± {sd(times[s, b]):.1f} ({mean(absent):.1f}), acc {acc:.3f}")
        report.add(
            f"| {s.value} | " + " | ".join(cells) + f" | {p_value(paired_p(times[s, BETAS[1]], times[s, BETAS[2]]))} |"
        )
    report.add("")

    report.plots["h3-beta"] = plots.h3_beta(times)
