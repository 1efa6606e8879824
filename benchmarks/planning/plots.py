"""The planning benchmark's figure: plan time and cost against the number of states, on log axes, ours
beside the paper's (Colledanchise et al. 2020, Tables I and II) and the authors' released code measured
on a machine like ours.

The figure is drawn from the numbers of Tables I and II (left) -- from the children's results when the
benchmark runs (:func:`points_from_results`), or read back from a written markdown
(:func:`points_from_markdown`), so that ``python -m benchmarks.planning --replot`` redraws the committed
figure from the committed results without rerunning anything. It is written beside the markdown
(``planning.png`` beside ``planning.md``) when matplotlib is installed, as ``benchmarks/search_paper``'s
figures are; matplotlib is reached through :mod:`beliefloc.render.figures` (deterministic PNG bytes,
written whole or not at all).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .paper import AUTHORS_CODE_HERE, PAPER_COST, PAPER_PLAN_S, PAPER_SIZES
from .settings import STRATEGY_ORDER

FIGURE_HEADING = "### Figure"
TABLE_HEADING = "## Tables I and II (left): plan time, replans, cost"
_STYLE = {"bestfirst": ("#1f77b4", "o"), "uniform": ("#ff7f0e", "s"), "random": ("#2ca02c", "^")}
"""A strategy's colour and marker; ours are solid lines and filled markers, the paper's dashed and hollow."""
_ROW = re.compile(r"^\|\s*\S+\s*\(([\d,]+)\)\s*\|\s*([a-z]+)\s*\|")


@dataclass(frozen=True)
class Point:
    """One row of Tables I and II: a strategy at a size, its mean plan time and mean cost (None: not
    measured, or not a planner)."""

    states: int
    strategy: str
    plan_s: float | None
    cost: float | None


def points_from_results(episodes: list[dict[str, Any]]) -> list[Point]:
    """The points of the children's episode results (``run_child`` of kind ``episodes``)."""
    points = []
    for result in episodes:
        for strategy in STRATEGY_ORDER:
            s = result["summary"].get(strategy)
            if s is None:
                continue
            plan_s = s["mean_plan_seconds"] if strategy != "random" else None
            points.append(Point(int(result["n_states"]), strategy, plan_s, s["mean_cost"]))
    return points


def points_from_markdown(text: str) -> list[Point]:
    """The points of the first table under :data:`TABLE_HEADING` in a written report; ValueError when
    there is no such table."""
    lines = text.splitlines()
    try:
        start = lines.index(TABLE_HEADING)
    except ValueError:
        raise ValueError(f"no {TABLE_HEADING!r} section: not a report of python -m benchmarks.planning") from None
    points = []
    in_table = False
    for line in lines[start + 1 :]:
        if not line.startswith("|"):
            if in_table:
                break
            continue
        in_table = True
        match = _ROW.match(line)
        if match is None:
            continue  # the header and its rule
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        points.append(Point(int(match.group(1).replace(",", "")), match.group(2), _number(cells[3]), _number(cells[8])))
    if not points:
        raise ValueError(f"the {TABLE_HEADING!r} section has no rows")
    return points


def _number(cell: str) -> float | None:
    """``0.0016 s`` or ``30.35`` -> a float; ``—`` or blank -> None."""
    text = cell.removesuffix(" s").replace(",", "").strip()
    try:
        return float(text)
    except ValueError:
        return None


def draw(fig: Any, points: list[Point]) -> None:
    """Two panels on ``fig``: mean plan time (Table I) and mean cost (Table II, left) against states,
    both axes logarithmic; ours solid with filled markers, the paper's dashed with hollow ones, the
    authors' code on our machine dotted with crosses."""
    time_ax = fig.add_subplot(1, 2, 1)
    cost_ax = fig.add_subplot(1, 2, 2)
    for ax, field, paper in ((time_ax, "plan_s", PAPER_PLAN_S), (cost_ax, "cost", PAPER_COST)):
        for strategy in STRATEGY_ORDER:
            colour, marker = _STYLE[strategy]
            ours = sorted((p.states, getattr(p, field)) for p in points if p.strategy == strategy)
            ours = [(n, v) for n, v in ours if v is not None]
            if ours:
                ax.plot(
                    [n for n, _ in ours],
                    [v for _, v in ours],
                    "-",
                    color=colour,
                    marker=marker,
                    label=f"{strategy}, ours",
                )
            theirs = [(n, v) for n, v in zip(PAPER_SIZES, paper.get(strategy, ()), strict=False) if v is not None]
            if theirs:
                ax.plot(
                    [n for n, _ in theirs],
                    [v for _, v in theirs],
                    "--",
                    color=colour,
                    marker=marker,
                    markerfacecolor="white",
                    label=f"{strategy}, paper",
                )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("states")
        ax.grid(True, which="major", linewidth=0.4, color="#cccccc")
    time_ax.plot(
        PAPER_SIZES, AUTHORS_CODE_HERE, ":", color="black", marker="x", label="bestfirst, authors' code on our machine"
    )
    time_ax.set(ylabel="mean plan time (s)", title="Table I: plan time")
    cost_ax.set(ylabel="mean cost of the episodes that localized", title="Table II (left): cost")
    costs = [p.cost for p in points if p.cost is not None] + [v for vs in PAPER_COST.values() for v in vs if v]
    ticks = [t for t in (10, 20, 30, 50, 100, 200, 300, 500, 1000) if min(costs) / 1.5 <= t <= max(costs) * 1.5]
    cost_ax.set_yticks(ticks, [str(t) for t in ticks])
    cost_ax.tick_params(axis="y", which="minor", labelleft=False)
    handles, labels = cost_ax.get_legend_handles_labels()
    more, more_labels = time_ax.get_legend_handles_labels()
    for handle, label in zip(more, more_labels, strict=True):
        if label not in labels:
            handles.append(handle)
            labels.append(label)
    fig.legend(handles, labels, loc="outside lower center", ncol=4, fontsize=8, frameon=False)


def write_plot(points: list[Point], path: Path) -> Path | None:
    """The figure as a PNG at ``path``; None (nothing written) when matplotlib is not installed."""
    from beliefloc.render.figures import PlotsMissingError, figure, save_figure

    try:
        with figure(11.0, 5.0) as fig:
            fig.set_layout_engine("constrained")
            draw(fig, points)
            save_figure(fig, path)
    except PlotsMissingError:
        return None
    return path


def figure_section(written: Path | None) -> list[str]:
    """The report's lines about the figure: a link to it, or why there is none."""
    if written is None:
        return [FIGURE_HEADING, "", "Plot skipped: matplotlib is not installed (`pip install -e '.[plots]'`).", ""]
    return [
        FIGURE_HEADING,
        "",
        f"![Plan time and cost against states, ours beside the paper's]({written.name})",
        "",
        f"`{written.name}`: the table above on log axes; redraw it from this file with "
        "`python -m benchmarks.planning --replot`.",
        "",
    ]


def with_figure_section(text: str, written: Path | None) -> str:
    """``text`` with its figure section replaced, or inserted before the ``### Outcomes`` section."""
    lines = text.split("\n")
    section = figure_section(written)
    if FIGURE_HEADING in lines:
        start = lines.index(FIGURE_HEADING)
        end = next((k for k in range(start + 1, len(lines)) if lines[k].startswith("#")), len(lines))
        return "\n".join(lines[:start] + section + lines[end:])
    at = lines.index("### Outcomes") if "### Outcomes" in lines else len(lines)
    return "\n".join(lines[:at] + section + lines[at:])
