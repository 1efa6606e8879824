"""Tables for pairwise selection (``select``) and macro tables (``macros build`` / ``show``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rich import box
from rich.table import Table


def weights_table(weights: dict[str, float], chosen: str | None, title: str) -> Table:
    """Every candidate's weight w(a) (Eq. 9), the chosen one (Eq. 10) marked."""
    table = Table(title=title, title_justify="left", box=box.SIMPLE_HEAD, min_width=len(title))
    table.add_column("candidate")
    table.add_column("w", justify="right")
    table.add_column("")
    for name, w in weights.items():
        table.add_row(name, f"{w:.4g}", "chosen" if name == chosen else "")
    return table


def edges_table(name: str, rows: Sequence[dict[str, Any]], shown: int, total: int) -> Table:
    """The edges behind one candidate's weight (Eq. 8): pairs, where they go, the factors."""
    more = f", the heaviest {shown} shown" if shown < total else ""
    table = Table(title=f"edges of {name}: {total}{more}", title_justify="left", box=box.SIMPLE_HEAD)
    for column in ("s_i", "s_j", "f*(s_i)", "f*(s_j)", "d", "Bel·Bel", "min p*", "C", "w"):
        table.add_column(column, justify="left" if column.startswith(("s", "f")) else "right")
    for r in rows:
        table.add_row(
            r["s_i"],
            r["s_j"],
            r["f_i"],
            r["f_j"],
            f"{r['difference']:.3g}",
            f"{r['belief_product']:.4g}",
            f"{r['min_probability']:.3g}",
            f"{r['cost']:g}",
            f"{r['weight']:.4g}",
        )
    return table


def macro_summary_table(summary: dict[str, Any], title: str) -> Table:
    table = Table(title=title, title_justify="left", box=box.SIMPLE_HEAD, show_header=False)
    table.add_column("what")
    table.add_column("value", justify="right")
    rows = [
        ("states", f"{summary['states']:,}"),
        ("indistinguishable pairs", f"{summary['indistinguishable_pairs']:,}"),
        ("pairs with a macro", f"{summary['pairs_with_macro']:,}"),
        ("distinct macros", f"{summary['macros']:,}"),
        ("macro length (max, mean)", f"{summary['max_length']}, {summary['mean_length']:.2f}"),
        ("never distinguishable pairs", f"{summary['never_distinguishable_pairs']:,}"),
        ("gamma", f"{summary['gamma']:.4g}"),
        ("seconds", f"{summary['seconds']:.3f}"),
    ]
    for what, value in rows:
        table.add_row(what, value)
    return table


def classes_table(classes: Sequence[Sequence[str]], limit: int = 20) -> Table:
    """The localizability verdict: groups of states the robot can never tell apart."""
    table = Table(
        title=f"{len(classes)} classes of states the robot can never tell apart",
        title_justify="left",
        box=box.SIMPLE_HEAD,
    )
    table.add_column("class", justify="right")
    table.add_column("states")
    for k, states in enumerate(classes[:limit], start=1):
        table.add_row(str(k), "  ".join(states))
    if len(classes) > limit:
        table.add_row("…", f"{len(classes) - limit} more")
    return table


def macro_path_table(title: str, steps: Sequence[dict[str, str]]) -> Table:
    """A macro's expected path from both states of a pair: the action, where each state goes, and
    the noise-free observation each reads there."""
    table = Table(title=title, title_justify="left", box=box.SIMPLE_HEAD)
    for column in ("step", "action", "s_i at", "s_i reads", "s_j at", "s_j reads"):
        table.add_column(column, justify="right" if column == "step" else "left")
    for k, step in enumerate(steps):
        table.add_row(str(k), step["action"], step["at_i"], step["reads_i"], step["at_j"], step["reads_j"])
    return table


def longest_macros_table(rows: Sequence[dict[str, Any]]) -> Table:
    table = Table(title="the longest macros", title_justify="left", box=box.SIMPLE_HEAD)
    table.add_column("s_i")
    table.add_column("s_j")
    table.add_column("cost", justify="right")
    table.add_column("actions")
    for r in rows:
        table.add_row(r["s_i"], r["s_j"], f"{r['cost']:g}", " ".join(r["actions"]))
    return table
