"""Contingent plans against best-first search: what a policy that branches on every observation
(``--strategy contingent``) buys in executed cost over replanning best-first search (``bestfirst``),
and what it costs in planning time and memory, in paired episodes.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_contingent.py              # 10^2, 10^3, 10^4 x 100, 10^5 x 10, maps x 200
    python benchmarks/bench_contingent.py --quick      # 3 episodes at 10^2 and 10^3, 5 per map (~10 s)
    python benchmarks/bench_contingent.py --episodes 20 --map-episodes 40 --big-size 0 --output /tmp/c.md

1. **Generated worlds in the authors' setting** (``--sizes``, default 10^2 10^3 10^4, ``--episodes``
   100 each; ``--big-size`` 10^5 with ``--big-episodes`` 10, 0 skips it): episode ``e`` is a fresh
   world built as ``benchmarks.planning`` builds it (world seed ``world_seed(seed, e)``,
   ``beliefloc generate gridworld --seen-model states --rotation-failure 0``), the uniform start
   belief, threshold 0.9 (``--threshold``). The true start and the noise are episode ``e``'s of
   :class:`beliefloc.simulation.episode.EpisodeSweep` with ``seed`` (``episode_rngs(seed, e)``), the
   same for both strategies (paired trials).
2. **The bundled maps** ``maps/kitchen.yaml`` and ``maps/hallway.yaml`` (``--maps``, e.g. ``--maps depot``):
   ``--map-episodes`` (200)
   paired episodes each, uniform starts and start belief, the command line's default threshold 0.95.

Both strategies get the same ``PlannerSettings`` (``--lookahead``, ``--prune-below``: the contingent
planner's, by default the library's defaults; the default budget of 200,000 expansions and 60 s per
plan call) and a step limit of ``--max-steps`` (500). Each size and each map runs in a child process
of its own (this script with ``--child``), so that its peak memory (``ru_maxrss``) is its own;
``OPENBLAS_NUM_THREADS=1``. The table goes to ``benchmarks/results/contingent.md``
(``contingent-quick.md`` for ``--quick``) and stdout, progress to stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository root: import benchmarks.*

from benchmarks.machine import cpu_name
from benchmarks.planning.settings import ROOT, peak_rss_mib, run_json_child, say, single_threaded
from benchmarks.planning.worlds import build_model, world_seed
from benchmarks.stats import DASH, difference_ci, fmt, mean, paired_p, win_counts

RESULTS = ROOT / "benchmarks" / "results" / "contingent.md"
STRATEGIES = ("bestfirst", "contingent")
MAPS = ("kitchen", "hallway")
THRESHOLD_WORLDS = 0.9
CONFIDENCE = 0.95

TARGET_STATES = 10_000
TARGET_COST_REDUCTION = 0.10
"""At 10^4 states the contingent mean cost is at least this fraction below bestfirst's (CI below 0)."""
TARGET_PLAN_SECONDS = 0.1
TARGET_PEAK_MIB = 1024.0


# --- the child processes: one size or one map each ---------------------------------------------------------


def _settings(p: dict[str, Any]) -> Any:
    """Both strategies' settings: the threshold, and the contingent options given (the library's defaults
    for the others)."""
    from beliefloc.simulation.strategies import PlannerSettings

    given = {key: p[key] for key in ("lookahead", "prune_below") if p[key] is not None}
    return PlannerSettings(threshold=p["threshold"], **given)


def effective_lookahead(settings: Any, n_states: int) -> int | None:
    """The beliefs the contingent planner expands per plan call on a model of ``n_states`` states:
    ``settings.lookahead``, or the library's size-dependent default when that is None (None if the
    library has no such default)."""
    if settings.lookahead is not None:
        return int(settings.lookahead)
    from beliefloc.planning import settings as planning_settings

    default = getattr(planning_settings, "default_lookahead", None)
    return None if default is None else int(default(n_states))


def _progress(tag: str, e: int, episodes: int, started: float, records: Sequence[Any]) -> None:
    parts = []
    for r in records:
        plan = f", {mean(r.plan_seconds):.4f} s/plan" if r.plan_seconds else ""
        parts.append(f"{r.strategy} {r.status.value} cost {r.cost:g}, {r.replans} replans{plan}")
    say(f"  [{tag}] episode {e + 1}/{episodes} ({time.perf_counter() - started:.0f} s): " + " | ".join(parts))


def child_worlds(p: dict[str, Any]) -> dict[str, Any]:
    """Episode ``e`` of both strategies on world ``e``, for ``e < episodes``: their records' JSON."""
    from beliefloc.simulation.episode import EpisodeSweep
    from beliefloc.simulation.strategies import SharedWork

    states, episodes = p["states"], p["episodes"]
    settings = _settings(p)
    records: list[dict[str, Any]] = []
    n_states: set[int] = set()
    lookahead: set[int | None] = set()
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench-contingent-") as tmp:
        for e in range(episodes):
            model = build_model(states, world_seed(p["seed"], e), Path(tmp), rotation_failure=0.0)
            n_states.add(model.n_states)
            lookahead.add(effective_lookahead(settings, model.n_states))
            sweep = EpisodeSweep(model, STRATEGIES, seed=p["seed"], settings=settings, max_steps=p["max_steps"])
            paired = sweep.paired(e, SharedWork.for_model(model))
            records += [r.as_json() for r in paired]
            _progress(f"{states:,} states", e, episodes, started, paired)
    return {
        "records": records,
        "n_states": sorted(n_states),
        "lookahead": sorted(lookahead, key=lambda x: -1 if x is None else x),
        "peak_mib": peak_rss_mib(),
        "seconds": time.perf_counter() - started,
    }


def child_map(p: dict[str, Any]) -> dict[str, Any]:
    """Paired episodes of both strategies on one bundled map."""
    from beliefloc.semantic_map import compile_model, load_map
    from beliefloc.simulation.episode import EpisodeSweep
    from beliefloc.simulation.strategies import SharedWork

    model = compile_model(load_map(ROOT / "maps" / f"{p['map']}.yaml"))
    settings = _settings(p)
    sweep = EpisodeSweep(model, STRATEGIES, seed=p["seed"], settings=settings, max_steps=p["max_steps"])
    shared = SharedWork.for_model(model)
    records: list[dict[str, Any]] = []
    started = time.perf_counter()
    for e in range(p["episodes"]):
        paired = sweep.paired(e, shared)
        records += [r.as_json() for r in paired]
        _progress(p["map"], e, p["episodes"], started, paired)
    return {
        "records": records,
        "n_states": [model.n_states],
        "lookahead": [effective_lookahead(settings, model.n_states)],
        "peak_mib": peak_rss_mib(),
        "seconds": time.perf_counter() - started,
    }


CHILDREN = {"worlds": child_worlds, "map": child_map}


def run_child(params: dict[str, Any]) -> dict[str, Any]:
    """Run one part in a fresh ``python benchmarks/bench_contingent.py --child`` at the repository root."""
    command = [sys.executable, str(Path(__file__).resolve()), "--child", json.dumps(params)]
    return run_json_child(command, params["label"])


# --- the statistics of a row ----------------------------------------------------------------------------------


def summarize_row(label: str, kind: str, result: dict[str, Any]) -> dict[str, Any]:
    """A row of the tables: each strategy's summary and the paired cost statistics."""
    from beliefloc.simulation.episode import EpisodeRecord, summarize

    records = [EpisodeRecord.from_json(data) for data in result["records"]]
    summary = summarize(records)
    by = {(r.strategy, r.episode): r for r in records}
    pairs = [
        (by[("contingent", e)].cost, by[("bestfirst", e)].cost)
        for (name, e) in by
        if name == "contingent" and ("bestfirst", e) in by
        if by[("contingent", e)].status.value == by[("bestfirst", e)].status.value == "localized"
    ]
    differences = [c - b for c, b in pairs]
    bestfirst_cost = mean(b for _, b in pairs)
    ci = difference_ci(differences, CONFIDENCE)
    cheaper, dearer = win_counts(pairs)
    return {
        "label": label,
        "kind": kind,
        "n_states": result["n_states"],
        "lookahead": result["lookahead"],
        "summary": summary,
        "pairs": len(pairs),
        "bestfirst_cost": bestfirst_cost,
        "contingent_cost": mean(c for c, _ in pairs),
        "difference": ci,
        "relative": ci[0] / bestfirst_cost if ci is not None and bestfirst_cost > 0 else None,
        "cheaper": cheaper,
        "dearer": dearer,
        "p": paired_p([c for c, _ in pairs], [b for _, b in pairs]) if pairs else None,
        "planning": {name: mean(sum(r.plan_seconds) for r in records if r.strategy == name) for name in STRATEGIES},
        "peak_mib": result["peak_mib"],
        "wall_s": result["wall_s"],
    }


def _num(value: float | None, digits: int) -> str:
    """:func:`benchmarks.stats.fmt`, with "—" for nan too (a mean of no values)."""
    return fmt(None if value is None or math.isnan(value) else value, digits)


def _ci(row: dict[str, Any]) -> str:
    ci = row["difference"]
    return DASH if ci is None else f"{ci[0]:+.2f} [{ci[1]:+.2f}, {ci[2]:+.2f}]"


def _relative(row: dict[str, Any]) -> str:
    return DASH if row["relative"] is None else f"{100 * row['relative']:+.1f} %"


def _states(row: dict[str, Any]) -> str:
    """The compiled models' state count, or its range over the row's worlds."""
    sizes = row["n_states"]
    if not sizes:
        return DASH
    return f"{sizes[0]:,}" if sizes[0] == sizes[-1] else f"{sizes[0]:,}-{sizes[-1]:,}"


def _lookahead(row: dict[str, Any]) -> str:
    """The contingent planner's expansions per plan call on the row's models."""
    values = row["lookahead"]
    if not values or None in values:
        return DASH
    return f"{values[0]:,}" if values[0] == values[-1] else f"{values[0]:,}-{values[-1]:,}"


# --- the report -----------------------------------------------------------------------------------------------


def verdict(ok: bool) -> str:
    return "MET" if ok else "NOT MET"


def targets(rows: list[dict[str, Any]], maps: Sequence[str] = MAPS) -> list[str]:
    lines = ["", "## Targets", ""]
    at = {row["label"]: row for row in rows}
    target = at.get(f"{TARGET_STATES:,} states")
    if target is None:
        lines.append("- 10^4 states: NOT MEASURED (10^4 is not in `--sizes`).")
    else:
        s = target["summary"]
        ci, relative = target["difference"], target["relative"]
        cost_ok = ci is not None and relative is not None and relative <= -TARGET_COST_REDUCTION and ci[2] < 0
        plan = s["contingent"].mean_plan_seconds
        plan_ok = plan is not None and plan <= TARGET_PLAN_SECONDS
        peak_ok = target["peak_mib"] <= TARGET_PEAK_MIB
        lines += [
            f"- 10^4 states, mean contingent cost at least {TARGET_COST_REDUCTION:.0%} below bestfirst's (paired) "
            f"with the {CONFIDENCE:.0%} CI of the difference below 0: {_num(target['contingent_cost'], 2)} against "
            f"{_num(target['bestfirst_cost'], 2)} (n={target['pairs']}; localized {s['contingent'].localized} / "
            f"{s['bestfirst'].localized} of {s['contingent'].episodes}), difference {_ci(target)}, "
            f"{_relative(target)}: **{verdict(cost_ok)}**",
            f"- 10^4 states, contingent mean plan time <= {TARGET_PLAN_SECONDS:g} s: {_num(plan, 4)} s: "
            f"**{verdict(plan_ok)}**",
            f"- 10^4 states, peak RSS <= {TARGET_PEAK_MIB:.0f} MiB: {target['peak_mib']:.0f} MiB: "
            f"**{verdict(peak_ok)}**",
        ]
    for name in maps:
        row = at.get(name)
        if row is None:
            lines.append(f"- {name}: NOT MEASURED.")
            continue
        ok = row["pairs"] > 0 and row["contingent_cost"] <= row["bestfirst_cost"]
        lines.append(
            f"- {name}, contingent mean cost <= bestfirst's (paired): {_num(row['contingent_cost'], 2)} against "
            f"{_num(row['bestfirst_cost'], 2)} (n={row['pairs']}): **{verdict(ok)}**"
        )
    return lines


def report(args: argparse.Namespace, rows: list[dict[str, Any]], total: float) -> str:
    import numpy as np
    import scipy

    from beliefloc.simulation.strategies import PlannerSettings

    command = shlex.join(["python", "benchmarks/bench_contingent.py", *args.argv])
    settings = PlannerSettings(**({} if args.prune_below is None else {"prune_below": args.prune_below}))
    lookahead = (
        f"{args.lookahead} beliefs expanded per plan call"
        if args.lookahead is not None
        else "the library's default number of beliefs expanded per plan call (column lookahead below)"
    )
    lines = [
        "# Contingent plans against best-first search",
        "",
        f"`{command}`",
        "",
        f"Machine: {cpu_name()}, {os.cpu_count()} cores, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"OPENBLAS_NUM_THREADS=1. Seed {args.seed}. Total wall time {total / 60:.1f} min; 1-minute load average "
        f"{args.load_start:.2f} at the start and {os.getloadavg()[0]:.2f} at the end.",
        "",
        "Paired episodes: in episode `e` both strategies start from the same true state, with the uniform start "
        "belief, and meet the same noise (`EpisodeSweep(model, ('bestfirst', 'contingent'), seed=SEED).paired(e)`). "
        f"Generated worlds: a fresh world per episode (`world_seed(SEED, e)`, `--seen-model states "
        f"--rotation-failure 0`, the authors' setting), threshold {args.threshold:g}. Maps: "
        f"{', '.join(f'`maps/{m}.yaml`' for m in args.maps)}, threshold {args.map_threshold:g}. Contingent: lookahead "
        f"{lookahead}, branches below {settings.prune_below:g} not planned for. Both: the "
        f"default budget (200,000 expansions, 60 s per plan call), at most {args.max_steps} steps.",
        "",
        "## Cost",
        "",
        "Means over the episodes both strategies localized (paired, n); difference contingent − bestfirst with its "
        f"{CONFIDENCE:.0%} confidence interval (t, n − 1 degrees of freedom); relative: the difference over "
        "bestfirst's mean; cheaper / dearer: episodes where contingent cost less / more; p: Wilcoxon signed-rank, "
        "two-sided.",
        "",
        f"| world | states | n | bestfirst cost | contingent cost | difference [{CONFIDENCE:.0%} CI] | relative "
        "| cheaper / dearer | p |",
        "| --- | --- | ---: | ---: | ---: | --- | ---: | --- | ---: |",
    ]
    for row in rows:
        lines.append(
            f"| {row['label']} | {_states(row)} | {row['pairs']} | {_num(row['bestfirst_cost'], 2)} | "
            f"{_num(row['contingent_cost'], 2)} | {_ci(row)} | {_relative(row)} | {row['cheaper']} / {row['dearer']} "
            f"| {_num(row['p'], 3)} |"
        )
    lines += [
        "",
        "## Episodes, planning time and memory",
        "",
        "Localized / correct: episodes localized, and those whose most likely state is the true one (b: bestfirst, "
        "c: contingent). Plan time is Table I's metric: per episode the mean over its plan calls, then the mean "
        "over episodes. Planning per episode: the sum over its plan calls, the mean over episodes (contingent "
        "plans on at every step while its policy is incomplete, so it makes more calls). Peak RSS: `ru_maxrss` "
        "of the child process that ran the row (both strategies, every world built).",
        "",
        "| world | episodes | lookahead | localized b / c | correct b / c | plan time b | plan time c | replans b "
        "| replans c | planning per episode b / c | peak RSS | wall time |",
        "| --- | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in rows:
        b, c = row["summary"]["bestfirst"], row["summary"]["contingent"]
        lines.append(
            f"| {row['label']} | {b.episodes} | {_lookahead(row)} | {b.localized} / {c.localized} | "
            f"{b.correct} / {c.correct} | "
            f"{_num(b.mean_plan_seconds, 4)} s | {_num(c.mean_plan_seconds, 4)} s | {_num(b.mean_replans, 2)} | "
            f"{_num(c.mean_replans, 2)} | {_num(row['planning']['bestfirst'], 3)} s / "
            f"{_num(row['planning']['contingent'], 3)} s | {row['peak_mib']:.0f} MiB | {row['wall_s']:.0f} s |"
        )
    lines += targets(rows, args.maps)
    return "\n".join(lines) + "\n"


# --- the command line -----------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--sizes", nargs="*", type=float, default=[1e2, 1e3, 1e4], help="sizes of the worlds")
    parser.add_argument("--episodes", type=int, help="episodes (worlds) per size (default 100; --quick: 3)")
    parser.add_argument("--big-size", type=float, default=1e5, help="one more size with fewer episodes (0: skip)")
    parser.add_argument("--big-episodes", type=int, default=10, help="episodes at --big-size")
    parser.add_argument("--map-episodes", type=int, help="paired episodes per bundled map (default 200; --quick: 5)")
    parser.add_argument(
        "--maps", nargs="*", default=list(MAPS), help="bundled maps (names in maps/) to run paired episodes on"
    )
    parser.add_argument("--threshold", type=float, default=THRESHOLD_WORLDS, help="threshold on generated worlds")
    parser.add_argument(
        "--lookahead", type=int, help="contingent: beliefs expanded per plan call (default: the library's default)"
    )
    parser.add_argument(
        "--prune-below",
        type=float,
        help="contingent: observation branches less likely than this are not planned for (default: the library's)",
    )
    parser.add_argument("--max-steps", type=int, default=500, help="step limit of an episode")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="a smoke run: 3 episodes at 10^2 and 10^3, 5 per map")
    parser.add_argument("--output", type=Path, help=f"markdown to write (default {RESULTS.name})")
    return parser


def main(argv: list[str] | None = None) -> int:
    single_threaded()  # before numpy's first import (here and, through the environment, in the children)
    from beliefloc.planning.settings import DEFAULT_THRESHOLD

    args = build_parser().parse_args(argv)
    if args.child:
        params = json.loads(args.child)
        print(json.dumps(CHILDREN[params["kind"]](params)))
        return 0
    args.argv = sys.argv[1:] if argv is None else argv
    if args.quick:
        args.sizes, args.big_size = [1e2, 1e3], 0
    args.episodes = args.episodes or (3 if args.quick else 100)
    args.map_episodes = args.map_episodes or (5 if args.quick else 200)
    args.map_threshold = DEFAULT_THRESHOLD
    args.load_start = os.getloadavg()[0]
    base = {
        "seed": args.seed,
        "lookahead": args.lookahead,
        "prune_below": args.prune_below,
        "max_steps": args.max_steps,
    }
    parts: list[tuple[str, str, dict[str, Any]]] = []
    worlds = [(int(s), args.episodes) for s in args.sizes]
    if args.big_size > 0:
        worlds.append((int(args.big_size), args.big_episodes))
    for states, episodes in worlds:
        label = f"{states:,} states"
        params = {**base, "kind": "worlds", "label": label, "states": states, "episodes": episodes}
        parts.append((label, "worlds", {**params, "threshold": args.threshold}))
    for name in args.maps:
        params = {**base, "kind": "map", "label": name, "map": name, "episodes": args.map_episodes}
        parts.append((name, "map", {**params, "threshold": args.map_threshold}))

    started = time.perf_counter()
    rows = []
    for label, kind, params in parts:
        say(f"... {label}: {params['episodes']} paired episodes")
        rows.append(summarize_row(label, kind, run_child(params)))
    text = report(args, rows, time.perf_counter() - started)
    output = args.output or (RESULTS.with_name("contingent-quick.md") if args.quick else RESULTS)
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
