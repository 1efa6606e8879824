"""Model-building performance: generate a random grid world, write and load its map, compile it,
and time one belief update, at about 10^4, 10^5 and 10^6 states.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_model.py                       # objects model at 1e4 1e5 1e6, states model at 1e5
    python benchmarks/bench_model.py --quick               # 1e3 and 1e4 only, a few seconds
    python benchmarks/bench_model.py --sizes 1e4 1e5 --states-sizes 1e4 --repeats 50

Every world is ``beliefloc generate gridworld`` (open grid, 4 headings, a look with 4 classes).
Each size runs in two fresh subprocesses, so that the peak resident memory (``ru_maxrss``) of one
size is not inflated by another: one generates and writes the map, the other loads, compiles and
updates. The table is printed and written to ``benchmarks/results/model.md``.

Targets on a 2-core machine (checked on the 10^6-state objects row): compile < 30 s, peak RSS of
the load + compile + update process < 2 GiB, one belief update < 50 ms.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository root: import benchmarks.*

from benchmarks.planning.settings import peak_rss_mib, run_json_child, single_threaded

RESULTS = Path(__file__).resolve().parent / "results" / "model.md"
TARGET_COMPILE_S = 30.0
TARGET_PEAK_MIB = 2048.0
TARGET_UPDATE_MS = 50.0
TARGET_STATES = 10**6


def child_generate(states: int, seen_model: str, seed: int, path: Path) -> dict[str, Any]:
    """Generate a world and write its map (what ``beliefloc generate gridworld`` does)."""
    import numpy as np

    from beliefloc.simulation.gridworld import generate_gridworld, gridworld_yaml
    from beliefloc.simulation.settings import SeenModel
    from beliefloc.source.atomic_write import write_atomically

    start = time.perf_counter()
    world = generate_gridworld(states, np.random.default_rng(seed), SeenModel(seen_model))
    text = gridworld_yaml(world, seed=seed).encode()
    write_atomically(path, lambda handle: handle.write(text))
    seconds = time.perf_counter() - start
    annotated = sum(len(s) for _, s in world.annotations()) if world.seen_states else 0
    return {
        "states": world.n_states,
        "grid": f"{world.rows}x{world.cols}",
        "objects": len(world.landmarks),
        "annotated_states": annotated,
        "generate_s": seconds,
        "file_mib": path.stat().st_size / 2**20,
        "generate_peak_mib": peak_rss_mib(),
    }


def child_model(path: Path, repeats: int) -> dict[str, Any]:
    """Load and compile a map, then time belief updates (median after a warm-up)."""
    from beliefloc.belief import uniform, update
    from beliefloc.semantic_map import compile_model, load_map

    start = time.perf_counter()
    smap = load_map(path)
    load_s = time.perf_counter() - start
    start = time.perf_counter()
    model = compile_model(smap)
    compile_s = time.perf_counter() - start
    belief = uniform(model.n_states)
    look = model.action("look")
    seen = look.observation.true_observation(model.n_states // 2)

    def median_ms(action: str, observation: int | str) -> float:
        update(model, belief, action, observation)  # warm-up
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            update(model, belief, action, observation)
            times.append(time.perf_counter() - start)
        return 1000.0 * statistics.median(times)

    return {
        "load_s": load_s,
        "compile_s": compile_s,
        "update_look_ms": median_ms("look", seen),
        "update_forward_ms": median_ms("forward", "none"),
        "look_observation": look.observation.name(seen),
        "transition_nonzeros": sum(a.transition.nnz for a in model.actuation_actions if a.transition is not None),
        "model_peak_mib": peak_rss_mib(),
    }


def _run_child(args: list[str]) -> dict[str, Any]:
    result = run_json_child([sys.executable, str(Path(__file__).resolve()), "--child", *args], " ".join(args))
    del result["wall_s"]  # each child times what it measures itself
    return result


def measure(states: int, seen_model: str, seed: int, repeats: int, directory: Path) -> dict[str, Any]:
    path = directory / f"world-{seen_model}-{states}.yaml"
    row = {"seen_model": seen_model, "requested": states}
    row.update(_run_child(["generate", str(states), seen_model, str(seed), str(path)]))
    row.update(_run_child(["model", str(path), str(repeats)]))
    path.unlink()
    return row


def table(rows: list[dict[str, Any]]) -> str:
    header = (
        "| seen model | states | grid | objects / annotated states | generate + write (s) | map file (MiB) "
        "| load (s) | compile (s) | peak RSS load+compile+update (MiB) | update look (ms) | update forward (ms) |"
    )
    lines = [header, "|" + " --- |" * 11]
    for r in rows:
        what = f"{r['objects']} objects" if r["seen_model"] == "objects" else f"{r['annotated_states']} states"
        lines.append(
            f"| {r['seen_model']} | {r['states']:,} | {r['grid']} | {what} | {r['generate_s']:.3f} "
            f"| {r['file_mib']:.1f} | {r['load_s']:.3f} | {r['compile_s']:.3f} | {r['model_peak_mib']:.0f} "
            f"| {r['update_look_ms']:.2f} | {r['update_forward_ms']:.2f} |"
        )
    return "\n".join(lines)


def verdict(rows: list[dict[str, Any]]) -> list[str]:
    """The targets, checked on the objects rows of at least 10^6 states."""
    big = [r for r in rows if r["seen_model"] == "objects" and r["states"] >= TARGET_STATES]
    if not big:
        return ["(no objects row with 10^6 states or more: targets not checked; run without --quick)"]
    out = []
    for r in big:
        checks = [
            ("compile", r["compile_s"], TARGET_COMPILE_S, "s"),
            ("peak RSS", r["model_peak_mib"], TARGET_PEAK_MIB, "MiB"),
            ("update look", r["update_look_ms"], TARGET_UPDATE_MS, "ms"),
            ("update forward", r["update_forward_ms"], TARGET_UPDATE_MS, "ms"),
        ]
        for name, value, limit, unit in checks:
            mark = "met" if value < limit else "MISSED"
            out.append(f"- {r['states']:,} states, {name}: {value:.2f} {unit} (target < {limit:g} {unit}): {mark}")
    return out


def main(argv: list[str] | None = None) -> int:
    single_threaded()
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    parser.add_argument("--sizes", nargs="*", type=float, default=[1e4, 1e5, 1e6], help="objects-model sizes")
    parser.add_argument("--states-sizes", nargs="*", type=float, default=[1e5], help="states-model sizes")
    parser.add_argument("--quick", action="store_true", help="sizes 1e3 1e4 (both models): a smoke run")
    parser.add_argument("--repeats", type=int, default=20, help="timed belief updates per size (median)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--output", type=Path, help=f"markdown file to write (default {RESULTS.name}, or model-quick.md)"
    )
    args = parser.parse_args(argv)
    if args.child:
        kind, *rest = args.child
        if kind == "generate":
            result = child_generate(int(rest[0]), rest[1], int(rest[2]), Path(rest[3]))
        else:
            result = child_model(Path(rest[0]), int(rest[1]))
        print(json.dumps(result))
        return 0
    sizes = [1e3, 1e4] if args.quick else args.sizes
    states_sizes = [1e3, 1e4] if args.quick else args.states_sizes
    runs = [("objects", int(s)) for s in sizes] + [("states", int(s)) for s in states_sizes]
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-model-") as tmp:
        for seen_model, states in runs:
            print(f"... {seen_model} {states:,} states", file=sys.stderr, flush=True)
            rows.append(measure(states, seen_model, args.seed, args.repeats, Path(tmp)))
    import numpy as np
    import scipy

    machine = (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"numpy {np.__version__}, scipy {scipy.__version__}, OPENBLAS_NUM_THREADS=1"
    )
    text = "\n".join(
        [
            "# Model-building benchmark",
            "",
            "`"
            + " ".join(["python", "benchmarks/bench_model.py", *(argv if argv is not None else sys.argv[1:])])
            + "`",
            "",
            f"Machine: {machine}. Seed {args.seed}; belief updates are the median of {args.repeats} after a "
            "warm-up, from the uniform belief (look: the noise-free observation of the middle state; forward: "
            "observation `none`).",
            "",
            table(rows),
            "",
            "Targets:",
            "",
            *verdict(rows),
            "",
        ]
    )
    output = args.output or (RESULTS.with_name("model-quick.md") if args.quick else RESULTS)
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
