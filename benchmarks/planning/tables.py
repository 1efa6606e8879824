"""The planning benchmark's tables, from the children's results: Tables I and II beside the paper's,
the outcomes, the k-th plan call's time, the closed-list ablation, the heuristics, Algorithm 1 against
``plan()``, and the speed targets."""

from __future__ import annotations

from typing import Any

from benchmarks.stats import DASH, fmt, mean_or_none, median_or_none, paired_means

from .paper import AUTHORS_CODE_HERE, PAPER_COST, PAPER_KTH_1E3, PAPER_PLAN_S, PAPER_REPLANS, paper_value
from .settings import (
    STRATEGY_ORDER,
    TARGET_COST_1E4,
    TARGET_PEAK_1E5_MIB,
    TARGET_PLAN_1E4_S,
    TARGET_PLAN_1E5_S,
    THRESHOLD,
)


def _s(value: float | None, digits: int = 4) -> str:
    """Seconds with ``digits`` decimals, or "—"."""
    return DASH if value is None else f"{value:.{digits}f} s"


def size_label(states: int) -> str:
    """``10^k`` for a power of ten, else the number with thousands separators."""
    exponent = len(str(states)) - 1
    return f"10^{exponent}" if states == 10**exponent else f"{states:,}"


def _runs(result: dict[str, Any], strategy: str) -> list[dict[str, Any]]:
    return [row["strategies"][strategy] for row in result["rows"] if strategy in row["strategies"]]


def table_one_two(episodes: list[dict[str, Any]]) -> list[str]:
    """Table I (plan time, replans) and Table II left (cost), ours beside the paper's."""
    lines = [
        "| size (states) | strategy | episodes | mean plan time | paper | authors' code, a machine like ours "
        "| mean replans | paper | mean cost (localized) | paper |",
        "|" + " --- |" * 10,
    ]
    for result in episodes:
        size = result["states"]
        for strategy in STRATEGY_ORDER:
            s = result["summary"].get(strategy)
            if s is None:
                continue
            planner = strategy != "random"
            time_s = s["mean_plan_seconds"] if planner else None
            replans = s["mean_replans"] if planner else None
            paper_t = _s(paper_value(PAPER_PLAN_S, strategy, size)) if planner else ""
            paper_r = fmt(paper_value(PAPER_REPLANS, strategy, size)) if planner else ""
            authors = (
                _s(paper_value({"bestfirst": AUTHORS_CODE_HERE}, strategy, size)) if strategy == "bestfirst" else ""
            )
            lines.append(
                f"| {size_label(size)} ({result['n_states']:,}) | {strategy} | {s['episodes']} | {_s(time_s)} "
                f"| {paper_t} | {authors} | {fmt(replans)} | {paper_r} "
                f"| {fmt(s['mean_cost'])} | {fmt(paper_value(PAPER_COST, strategy, size))} |"
            )
    return lines


def table_outcomes(episodes: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | strategy | episodes | localized | correct | no_plan | budget_exceeded | step_limit "
        "| other | mean steps (localized) | paired cost: this / bestfirst | peak RSS (MiB) | wall (s) |",
        "|" + " --- |" * 13,
    ]
    for result in episodes:
        for strategy in [st for st in STRATEGY_ORDER if st in result["summary"]]:
            s = result["summary"][strategy]
            failures = dict(s["failures"])
            known = [failures.pop(k, 0) for k in ("no_plan", "budget_exceeded", "step_limit")]
            other = ", ".join(f"{k} {v}" for k, v in failures.items()) or "0"
            paired = "" if strategy == "bestfirst" else _paired_cost(result["rows"], strategy)
            lines.append(
                f"| {size_label(result['states'])} | {strategy} | {s['episodes']} | {s['localized']} | {s['correct']} "
                f"| {known[0]} | {known[1]} | {known[2]} | {other} | {fmt(s['mean_steps'], 1)} "
                f"| {paired} | {result['peak_mib']:.0f} | {result['wall_s']:.0f} |"
            )
    return lines


def _paired_cost(rows: list[dict[str, Any]], strategy: str) -> str:
    """Mean cost of ``strategy`` and of bestfirst over the episodes where both localized."""
    both = [
        (r["strategies"][strategy]["cost"], r["strategies"]["bestfirst"]["cost"])
        for r in rows
        if all(r["strategies"].get(st, {}).get("status") == "localized" for st in (strategy, "bestfirst"))
    ]
    return paired_means(both)


def kth_plan_times(result: dict[str, Any], strategy: str = "bestfirst", ks: int = 3) -> list[tuple[float | None, int]]:
    """Mean over episodes of the k-th plan call's time (k = 1 is the first plan), and how many episodes had it."""
    out = []
    for k in range(1, ks + 1):
        values = [r["plan_seconds"][k - 1] for r in _runs(result, strategy) if len(r["plan_seconds"]) >= k]
        out.append((mean_or_none(values), len(values)))
    return out


def table_kth(episodes: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | 1st (first plan) | 2nd (1st replan) | 3rd (2nd replan) | all later calls (k >= 2) | first / later |",
        "|" + " --- |" * 6,
    ]
    for result in episodes:
        cells = [f"{_s(t)} (n={n})" for t, n in kth_plan_times(result)]
        first, later = first_and_later(result)
        ratio = f"{first / later:.1f}x" if first and later else DASH
        lines.append(f"| {size_label(result['states'])} | {' | '.join(cells)} | {_s(later)} | {ratio} |")
    lines.append(f"| paper, 10^3 | {_s(PAPER_KTH_1E3[0])} | {_s(PAPER_KTH_1E3[1])} | {_s(PAPER_KTH_1E3[2])} | | |")
    return lines


def first_and_later(result: dict[str, Any], strategy: str = "bestfirst") -> tuple[float | None, float | None]:
    """Mean time of plan call #1 and mean time of every later call (pooled over episodes)."""
    runs = _runs(result, strategy)
    first = mean_or_none([r["plan_seconds"][0] for r in runs if r["plan_seconds"]])
    later = mean_or_none([t for r in runs for t in r["plan_seconds"][1:]])
    return first, later


def table_ablation(episodes: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | replans | mean time, closed list kept | mean time, empty closed list | mean expanded, kept "
        "| mean expanded, empty |",
        "|" + " --- |" * 6,
    ]
    for result in episodes:
        items = [a for row in result["rows"] for a in row["ablation"]]
        lines.append(
            f"| {size_label(result['states'])} | {len(items)} | {_s(mean_or_none([a['memory_s'] for a in items]))} "
            f"| {_s(mean_or_none([a['fresh_s'] for a in items]))} "
            f"| {fmt(mean_or_none([a['memory_expanded'] for a in items]), 1)} "
            f"| {fmt(mean_or_none([a['fresh_expanded'] for a in items]), 1)} |"
        )
    return lines


def table_heuristics(heuristics: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | heuristic | worlds | found | budget exceeded | median expanded | mean expanded "
        "| expanded / entropy-max-prob (median) | mean first-plan cost (found) | paired cost: this / entropy-max-prob "
        "| mean time | replayed to >= 0.95 |",
        "|" + " --- |" * 12,
    ]
    for result in heuristics:
        rows = result["rows"]
        names = list(rows[0]["results"]) if rows else []
        for h in names:
            mine = [r["results"][h] for r in rows]
            found = [v for v in mine if v["status"] == "found"]
            ratios = [
                r["results"][h]["expanded"] / max(1, r["results"]["entropy-max-prob"]["expanded"])
                for r in rows
                if "entropy-max-prob" in r["results"]
            ]
            budget = sum(v["status"] == "budget_exceeded" for v in mine)
            lower = " (at least: budget hit)" if budget and h != "entropy-max-prob" else ""
            replayed = sum(v["replay"] is not None and v["replay"] >= THRESHOLD for v in found)
            lines.append(
                f"| {size_label(result['states'])} | {h} | {len(mine)} | {len(found)} | {budget} "
                f"| {fmt(median_or_none([v['expanded'] for v in mine]), 0)} "
                f"| {fmt(mean_or_none([v['expanded'] for v in mine]), 0)} "
                f"| {fmt(median_or_none(ratios), 1)}{lower} | {fmt(mean_or_none([v['cost'] for v in found]))} "
                f"| {_paired_first_cost(rows, h)} "
                f"| {_s(mean_or_none([v['seconds'] for v in mine]))} | {replayed}/{len(found)} |"
            )
    return lines


def _paired_first_cost(rows: list[dict[str, Any]], heuristic: str) -> str:
    """Mean first-plan cost of ``heuristic`` and of the default over the worlds where both found a plan."""
    both = [
        (r["results"][heuristic]["cost"], r["results"]["entropy-max-prob"]["cost"])
        for r in rows
        if r["results"][heuristic]["cost"] is not None and r["results"]["entropy-max-prob"]["cost"] is not None
    ]
    return "" if heuristic == "entropy-max-prob" else paired_means(both)


def baseline_ratios(result: dict[str, Any], variant: str) -> list[float]:
    return [
        r[variant]["seconds"] / r["plan"]["seconds"] for r in result["rows"] if variant in r and r["plan"]["seconds"]
    ]


def table_baseline(baselines: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | duplicates | worlds | plan(): median time | Algorithm 1: median time | time limit hit "
        "| ratio, median (min-max) | plan(): mean expanded | Algorithm 1: mean expanded "
        "| plan(): mean cost | Algorithm 1: mean cost | same cost | both replay to >= 0.95 |",
        "|" + " --- |" * 13,
    ]
    for result in baselines:
        rows = result["rows"]
        for variant in ("tolerance", "exact"):
            mine = [r for r in rows if variant in r]
            if not mine:
                continue
            ratios = baseline_ratios(result, variant)
            hits = sum(r[variant]["status"] != "found" for r in mine)
            both = [r for r in mine if r[variant]["cost"] is not None and r["plan"]["cost"] is not None]
            same = sum(r[variant]["cost"] == r["plan"]["cost"] for r in both)
            replayed = sum(r[variant]["replay"] >= THRESHOLD and r["plan"]["replay"] >= THRESHOLD for r in both)
            spread = f"{fmt(median_or_none(ratios), 1)}x ({min(ratios):.1f}-{max(ratios):.1f})" if ratios else DASH
            label = "max abs diff <= 2^-31" if variant == "tolerance" else "exact (==)"
            lines.append(
                f"| {size_label(result['states'])} | {label} | {len(mine)} "
                f"| {_s(median_or_none([r['plan']['seconds'] for r in mine]))} "
                f"| {_s(median_or_none([r[variant]['seconds'] for r in mine]))} | {hits} | {spread} "
                f"| {fmt(mean_or_none([r['plan']['expanded'] for r in mine]), 1)} "
                f"| {fmt(mean_or_none([r[variant]['expanded'] for r in mine]), 1)} "
                f"| {fmt(mean_or_none([r['plan']['cost'] for r in both]))} "
                f"| {fmt(mean_or_none([r[variant]['cost'] for r in both]))} "
                f"| {same}/{len(both)} | {replayed}/{len(both)} |"
            )
    return lines


def verdict(episodes: list[dict[str, Any]], big: dict[str, Any] | None) -> list[str]:
    """The speed targets, each with the measured figure and met / NOT MET."""
    out = []

    def mark(ok: bool) -> str:
        return "met" if ok else "NOT MET"

    at_1e4 = [r for r in episodes if r["states"] == 10_000]
    if at_1e4:
        s = at_1e4[0]["summary"]["bestfirst"]
        t, c = s["mean_plan_seconds"], s["mean_cost"]
        out.append(
            f"- 10^4 states, bestfirst mean plan time {_s(t)} (target <= {TARGET_PLAN_1E4_S} s): "
            f"{mark(t is not None and t <= TARGET_PLAN_1E4_S)}"
        )
        out.append(
            f"- 10^4 states, bestfirst mean episode cost {fmt(c)} over {s['localized']} localized episodes "
            f"(target <= {TARGET_COST_1E4:g}): {mark(c is not None and c <= TARGET_COST_1E4)}"
        )
    else:
        out.append("- 10^4 states: not run (targets not checked)")
    if big is not None:
        s = big["summary"]["bestfirst"]
        t = s["mean_plan_seconds"]
        out.append(
            f"- {big['n_states']:,} states ({s['episodes']} episodes), bestfirst mean plan time {_s(t)} "
            f"(target <= {TARGET_PLAN_1E5_S} s): {mark(t is not None and t <= TARGET_PLAN_1E5_S)}"
        )
        out.append(
            f"- {big['n_states']:,} states, peak RSS of its process {big['peak_mib']:.0f} MiB "
            f"(target <= {TARGET_PEAK_1E5_MIB:.0f} MiB): {mark(big['peak_mib'] <= TARGET_PEAK_1E5_MIB)}"
        )
    else:
        out.append("- 10^5 states: not run (targets not checked)")
    for result in [*episodes, *([big] if big else [])]:
        first, later = first_and_later(result)
        ok = first is not None and later is not None and later < first
        out.append(
            f"- {size_label(result['states'])}, replans (closed list kept) cheaper than first plans: "
            f"first {_s(first)}, later {_s(later)}: {mark(ok)}"
        )
    return out
