"""The planning benchmark's command line: its options, and the parts run one child process each, in
order (episodes per size, the big size, heuristics, baseline), then the markdown written and printed."""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from benchmarks import planning

from .children import CHILDREN, run_child
from .plots import points_from_markdown, points_from_results, with_figure_section, write_plot
from .report import report
from .settings import HEURISTICS, RESULTS, say, single_threaded

PROG = "python -m benchmarks.planning"


def build_parser() -> argparse.ArgumentParser:
    """The benchmark's options (``--child`` is the parts' internal entry point)."""
    parser = argparse.ArgumentParser(
        prog=PROG, description=planning.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--sizes", nargs="*", type=float, default=[1e2, 1e3, 1e4], help="sizes of Tables I and II")
    parser.add_argument("--episodes", type=int, help="episodes (worlds) per size (default 100; --quick: 3)")
    parser.add_argument("--quick", action="store_true", help="a smoke run: 3 episodes at 10^2 and 10^3, 2 worlds")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--workers",
        type=int,
        default=1,
        help="worker processes for the episodes' worlds (0: one per core). The results are the same; plan "
        "times then share the cores, so Table I's times are measured with 1 (the default)",
    )
    parser.add_argument("--max-steps", type=int, default=500, help="step limit of an episode")
    parser.add_argument("--uniform-time-limit", type=float, default=30.0, help="uniform: seconds per plan call")
    parser.add_argument("--uniform-max-expansions", type=int, default=200_000, help="uniform: expansions per plan")
    parser.add_argument(
        "--uniform-large-episodes",
        type=int,
        default=10,
        help="uniform runs on only this many episodes at 10^4 states and more (infeasible there; 0 skips it)",
    )
    parser.add_argument("--big-size", type=float, default=1e5, help="the size of the 10^5 target (0: skip)")
    parser.add_argument("--big-episodes", type=int, default=20, help="episodes at --big-size (bestfirst, random)")
    parser.add_argument("--heuristic-worlds", type=int, default=10, help="worlds per size for the heuristics")
    parser.add_argument("--heuristic-time-limit", type=float, default=20.0, help="seconds per heuristics plan")
    parser.add_argument("--baseline-worlds", type=int, default=10, help="worlds per size for the baseline")
    parser.add_argument("--baseline-time-limit", type=float, default=60.0, help="seconds per baseline plan")
    parser.add_argument(
        "--rotation-failure",
        type=float,
        help="worlds made with generate gridworld --rotation-failure P (0: the authors' code; default: 0.02)",
    )
    parser.add_argument("--output", type=Path, help=f"markdown to write (default {RESULTS.name}, or planning-quick.md)")
    parser.add_argument(
        "--replot",
        action="store_true",
        help="run nothing: redraw the figure (the .png beside --output) from the numbers of the markdown written",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    single_threaded()
    args = build_parser().parse_args(argv)
    if args.child:
        params = json.loads(args.child)
        print(json.dumps(CHILDREN[params["kind"]](params)))
        return 0
    if args.replot:
        return replot(args.output or (RESULTS.with_name("planning-quick.md") if args.quick else RESULTS))
    if args.quick:
        args.sizes, args.big_size = [1e2, 1e3], 0
        args.heuristic_worlds = args.baseline_worlds = 2
    args.episodes = args.episodes or (3 if args.quick else 100)
    sizes = [int(s) for s in args.sizes]
    started = time.perf_counter()
    args.load_start = os.getloadavg()[0]
    base = {"seed": args.seed, "rotation_failure": args.rotation_failure}

    episodes = []
    for states in sizes:
        uniform_episodes = args.episodes if states < 10_000 else min(args.episodes, args.uniform_large_episodes)
        say(f"... episodes at {states:,} states ({args.episodes}; uniform on {uniform_episodes})")
        params = {
            **base,
            "kind": "episodes",
            "tag": "episodes",
            "states": states,
            "episodes": args.episodes,
            "strategies": ["bestfirst", "random"],
            "uniform": uniform_episodes > 0,
            "uniform_episodes": uniform_episodes,
            "uniform_time_limit": args.uniform_time_limit,
            "uniform_max_expansions": args.uniform_max_expansions,
            "max_steps": args.max_steps,
            "workers": args.workers,
        }
        episodes.append(run_child(params))
    big = None
    if args.big_size:
        say(f"... episodes at {int(args.big_size):,} states ({args.big_episodes}, bestfirst and random)")
        big = run_child(
            {
                **base,
                "kind": "episodes",
                "tag": "big",
                "states": int(args.big_size),
                "episodes": args.big_episodes,
                "strategies": ["bestfirst", "random"],
                "uniform": False,
                "uniform_episodes": 0,
                "uniform_time_limit": args.uniform_time_limit,
                "uniform_max_expansions": args.uniform_max_expansions,
                "max_steps": args.max_steps,
                "workers": args.workers,
            }
        )
    heuristics = []
    for states in sizes:
        worlds = min(args.heuristic_worlds, args.episodes)
        say(f"... heuristics at {states:,} states ({worlds} worlds)")
        heuristics.append(
            run_child(
                {
                    **base,
                    "kind": "heuristics",
                    "states": states,
                    "worlds": worlds,
                    "heuristics": list(HEURISTICS),
                    "time_limit": args.heuristic_time_limit,
                    "max_expansions": args.uniform_max_expansions,
                }
            )
        )
    baselines = []
    for states in sizes:
        worlds = min(args.baseline_worlds, args.episodes)
        say(f"... baseline at {states:,} states ({worlds} worlds)")
        baselines.append(
            run_child(
                {**base, "kind": "baseline", "states": states, "worlds": worlds, "time_limit": args.baseline_time_limit}
            )
        )
    total = time.perf_counter() - started
    text = report(args, argv, episodes, big, heuristics, baselines, total)
    output = args.output or (RESULTS.with_name("planning-quick.md") if args.quick else RESULTS)
    output.parent.mkdir(parents=True, exist_ok=True)
    written = write_plot(points_from_results(episodes + ([big] if big else [])), output.with_suffix(".png"))
    text = with_figure_section(text, written)
    output.write_text(text)
    print(text)
    return 0


def replot(output: Path) -> int:
    """Redraw the figure beside ``output`` from the tables it holds, and link it from there."""
    text = output.read_text()
    written = write_plot(points_from_markdown(text), output.with_suffix(".png"))
    updated = with_figure_section(text, written)
    if updated != text:
        output.write_text(updated)
    say(f"figure {'skipped: matplotlib is not installed' if written is None else f'written to {written}'}")
    return 0 if written is not None else 1
