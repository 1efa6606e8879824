"""The PNG figures (with matplotlib, when installed): each section hands its figures' data to a function
here that returns the drawing, and :func:`write_plots` draws them beside the markdown."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from beliefloc.object_search.settings import Metareasoning
from benchmarks.stats import mean, standard_error

from .paper import PAPER_FIG6_WITHIN4, PAPER_FIG7, PAPER_H2_ACCURACY_FULL
from .report import Report
from .settings import BETAS, H3_LIMITS, KNOWLEDGE, METAREASONING

Draw = Callable[[Any], None]
"""Draws a figure on a matplotlib Axes (or on a Figure, for two axes)."""


def h1(table: dict[tuple[float, bool, int], float]) -> Draw:
    def draw(ax: Any) -> None:
        x = [100 * level for level in KNOWLEDGE]
        for defaults, style in ((False, "-"), (True, "--")):
            for k, marker in ((1, "o"), (2, "s")):
                label = f"top-{k}, {'with' if defaults else 'without'} defaults"
                ax.plot(x, [table[lv, defaults, k] for lv in KNOWLEDGE], style, marker=marker, label=label)
        ax.plot([40, 40, 100], [0.7, 0.9, 1.0], "k*", markersize=12, label="paper (read from the text)")
        ax.set(xlabel="domain knowledge (%)", ylabel="room accuracy", title="H1: ASP alone (Fig. 4)", ylim=(0, 1.05))
        ax.legend(fontsize=8)

    return draw


def h2_knowledge(rows: dict[tuple[float, bool], dict[str, float | None]]) -> Draw:
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

    return draw


def h2_cdf(errors: dict[str, list[float]]) -> Draw:
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

    return draw


def h3_time_accuracy(curve: list[tuple[float, float]], by_metareasoning: dict[Metareasoning, dict[str, float]]) -> Draw:
    def draw(ax: Any) -> None:
        ax.plot([t for t, _ in curve], [a for _, a in curve], "k-+", markersize=10, label="baseline (time limits)")
        for limit, (t, a) in zip(H3_LIMITS, curve, strict=True):
            ax.annotate(f"{limit:g}", (t, a), textcoords="offset points", xytext=(3, -10), fontsize=7)
        for s, marker in zip(METAREASONING, ("o", "s", "D"), strict=True):
            ax.plot(by_metareasoning[s]["time"], by_metareasoning[s]["acc"], marker, markersize=9, label=s.value)
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

    return draw


def h3_beta(times: dict[tuple[Metareasoning, tuple[float, float]], list[float]]) -> Draw:
    def draw(ax: Any) -> None:
        width = 0.25
        for k, b in enumerate(BETAS):
            xs = [i + (k - 1) * width for i in range(len(METAREASONING))]
            ys = [mean(times[s, b]) for s in METAREASONING]
            err = [standard_error(times[s, b]) for s in METAREASONING]
            ax.bar(xs, ys, width, yerr=err, capsize=3, label=f"Beta({b[0]:g}, {b[1]:g})")
        ax.set_xticks(range(len(METAREASONING)), [s.value for s in METAREASONING])
        ax.set(ylabel="mean localisation time (± s.e.)", title="Fig. 8: one mean, three variances, τ- = 0.85")
        ax.legend(fontsize=8)

    return draw


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
