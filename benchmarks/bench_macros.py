"""Khalvati & Mackworth's Tables I and II, and the speed of macro building and selection.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_macros.py              # corridors-large (10^4 states), 100 trials; ~10 min
    python benchmarks/bench_macros.py --quick      # maps/corridors.yaml, 20 trials, small build map; ~1 min
    python benchmarks/bench_macros.py --trials 1000 --output /tmp/macros.md

1. **Build**, each in a fresh subprocess (peak RSS = ``ru_maxrss``): the macros of a map of at least
   10^5 states with at least 10^6 look-alike pairs (the corridors pattern with two passive floor
   marks, so that look-alike groups stay small: :func:`marked_map`), and of the benchmark map.
   Targets: < 60 s and < 4 GiB.
2. **Tables I and II**: paired trials of ``ec2-macros`` (Algorithm 3) and ``ec2`` (Algorithm 1, a
   random basic action when no action has a positive weight) from the same start and noise, starts
   drawn among the states that share their noise-free observation with another state, uniform
   start belief, localized when one state holds 0.95, at most 500 basic actions. Table I: fraction
   localized; Table II: mean basic actions over the trials both strategies localized.
3. **Selection** with macros: the mean time of one ``ec2-macros`` decision over those episodes, on
   the benchmark map (about 10^4 states). Target: < 10 ms.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import string
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from stats import mean_or_none  # benchmarks/stats.py (scripts run from benchmarks/ on sys.path)

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "macros.md"
PAPER = {"ec2-macros": (1.0, 25.61), "ec2": (0.862, 79.13)}
TARGET_BUILD_S, TARGET_BUILD_MIB, TARGET_SELECT_MS = 60.0, 4096.0, 10.0


def _peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def corridor_layout(n_corridors: int, length: int, seed: int, gap: int = 3) -> Any:
    """``n_corridors`` corridors of ``length`` cells, ``gap`` blocked rows apart, joined by
    connectors at random columns, one dead-end stub each (how maps/corridors*.yaml were made)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    rows, cols = n_corridors * (gap + 1) + 1, length + 2
    free = np.zeros((rows, cols), dtype=bool)
    for k in range(n_corridors):
        r = 1 + k * (gap + 1)
        free[r, 1 : cols - 1] = True
        if k + 1 < n_corridors:
            for c in rng.choice(np.arange(1, cols - 1), size=max(2, length // 15), replace=False):
                free[r : r + gap + 2, c] = True
    for k in range(n_corridors):
        r = 1 + k * (gap + 1)
        c = int(rng.integers(1, cols - 1))
        if r + 1 < rows - 1 and not free[r + 1, c]:
            free[r + 1, c] = True
    return free


def marked_map(n_corridors: int, length: int, seed: int) -> dict[str, Any]:
    """The corridors pattern with the three-beam range sensor and two passive floor marks per cell
    (62 and 20 random labels): big, yet with small groups of look-alike states."""
    import numpy as np

    free = corridor_layout(n_corridors, length, seed)
    rng = np.random.default_rng(seed + 1)
    alphabet = string.ascii_letters + string.digits

    def labels(k: int) -> str:
        return "\n".join("".join(alphabet[v] for v in row) for row in rng.integers(0, k, size=free.shape))

    move = {"cost": 1, "failure": 0.15}
    return {
        "name": "marked-corridors",
        "grid": {"rows": int(free.shape[0]), "cols": int(free.shape[1]), "headings": 4},
        "layout": "\n".join("".join("." if f else "#" for f in row) for row in free),
        "actions": {name: move for name in ("forward", "backward", "rotate_cw", "rotate_ccw")},
        "sensors": {
            "range": {
                "type": "scan",
                "passive": True,
                "as_action": False,
                "beams_deg": [90, 0, -90],
                "bins": [0.5, 1.5],
                "error": 0.05,
            },
            "mark": {"type": "here", "passive": True, "as_action": False, "labels": labels(62)},
            "tile": {"type": "here", "passive": True, "as_action": False, "labels": labels(20)},
        },
    }


def child_build(spec: str, output: str) -> dict[str, Any]:
    """Compile a map and build its macros; report time and peak memory."""
    from beliefloc import compile_model, load_map
    from beliefloc.files.macro_file import save_macros
    from beliefloc.planning.macros import build_macros
    from beliefloc.semantic_map import SemanticMap

    if spec.startswith("marked:"):
        n_corridors, length = (int(x) for x in spec.split(":")[1].split(","))
        model = compile_model(SemanticMap.model_validate(marked_map(n_corridors, length, 5)))
    else:
        model = compile_model(load_map(spec))
    table = build_macros(model)
    if output:
        save_macros(table, output, model=model)
    return {**table.summary(), "name": model.name, "peak_mib": _peak_rss_mib()}


def _run_child(args: list[str]) -> dict[str, Any]:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, __file__, *args], check=True, capture_output=True, text=True, env=env)
    result: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def tables(map_path: str, macros_path: str, trials: int, seed: int, max_actions: int) -> dict[str, Any]:
    """Tables I and II: paired episodes of ec2-macros and ec2."""
    import numpy as np

    from beliefloc import compile_model, load_map
    from beliefloc.files.macro_file import load_macros
    from beliefloc.planning.ec2 import pair_context
    from beliefloc.simulation.episode import run_episode
    from beliefloc.simulation.strategies import EpisodeStatus, PlannerSettings

    model = compile_model(load_map(map_path))
    table = load_macros(macros_path, model)
    sig = pair_context(model, table.gamma).full_signature
    _, inverse, counts = np.unique(sig, return_inverse=True, return_counts=True)
    eligible = np.flatnonzero(counts[inverse.ravel()] > 1)
    rng = np.random.default_rng(seed)
    starts = rng.choice(eligible, size=trials)
    belief = np.full(model.n_states, 1.0 / model.n_states)
    settings = PlannerSettings(macros=table)
    records: dict[str, list[Any]] = {"ec2-macros": [], "ec2": []}
    for e, start in enumerate(starts.tolist()):
        for name in records:
            records[name].append(
                run_episode(model, name, start, belief, seed=seed, episode=e, settings=settings, max_steps=max_actions)
            )
    both = [e for e in range(trials) if all(records[n][e].status is EpisodeStatus.LOCALIZED for n in records)]
    out: dict[str, Any] = {"states": model.n_states, "eligible": len(eligible), "trials": trials, "both": len(both)}
    for name, recs in records.items():
        decisions = [t for r in recs for t in r.plan_seconds]
        out[name] = {
            "localized": sum(r.status is EpisodeStatus.LOCALIZED for r in recs) / trials,
            "correct": sum(r.correct for r in recs) / trials,
            "mean_actions_both": mean_or_none([recs[e].steps for e in both]),
            "mean_actions_own": mean_or_none([r.steps for r in recs if r.status is EpisodeStatus.LOCALIZED]),
            "mean_decision_ms": 1000 * statistics.fmean(decisions) if decisions else None,
            "max_decision_ms": 1000 * max(decisions) if decisions else None,
        }
    return out


def _report(build: list[dict[str, Any]], result: dict[str, Any], map_path: str, seconds: float) -> str:
    lines = [
        "# Macro actions: Khalvati & Mackworth Tables I and II, and speed",
        "",
        f"`python benchmarks/bench_macros.py {' '.join(sys.argv[1:])}` on {platform.machine()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}; {seconds:.0f} s in all.",
        "",
        "## Building macros (fresh subprocess each)",
        "",
        "| map | states | look-alike pairs | distinct macros | max length | mean length | never | seconds | peak MiB |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for b in build:
        lines.append(
            f"| {b['name']} | {b['states']:,} | {b['indistinguishable_pairs']:,} | {b['macros']:,} | "
            f"{b['max_length']} | {b['mean_length']:.2f} | {b['never_distinguishable_pairs']} | "
            f"{b['seconds']:.1f} | {b['peak_mib']:.0f} |"
        )
    big = build[0]
    ok = big["seconds"] < TARGET_BUILD_S and big["peak_mib"] < TARGET_BUILD_MIB
    lines += [
        "",
        f"Target (>= 10^5 states, >= 10^6 pairs: < {TARGET_BUILD_S:g} s, < {TARGET_BUILD_MIB:g} MiB) on "
        f"{big['name']}: {'met' if ok else 'NOT met'}.",
        "",
        f"## Tables I and II on `{map_path}` ({result['states']:,} states)",
        "",
        f"{result['trials']} paired trials, starts among the {result['eligible']:,} states that share their "
        f"noise-free observation with another state; both strategies localized in {result['both']}.",
        "",
        "| method | fraction localized (< 500 actions) | paper | mean basic actions (both localized) | paper "
        "| mean decision ms | max decision ms |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name, label in (("ec2-macros", "Macro actions"), ("ec2", "Basic actions and random walk")):
        r = result[name]
        frac, actions = PAPER[name]
        mean = "-" if r["mean_actions_both"] is None else f"{r['mean_actions_both']:.2f}"
        lines.append(
            f"| {label} | {100 * r['localized']:.1f} % | {100 * frac:.1f} % | {mean} | {actions} | "
            f"{r['mean_decision_ms']:.2f} | {r['max_decision_ms']:.1f} |"
        )
    sel = result["ec2-macros"]["mean_decision_ms"]
    lines += [
        "",
        f"Target (selection with macros at ~10^4 states < {TARGET_SELECT_MS:g} ms per decision): "
        f"{'met' if sel < TARGET_SELECT_MS else 'NOT met'} ({sel:.2f} ms mean).",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="maps/corridors.yaml, 20 trials, a small build map")
    parser.add_argument("--trials", type=int, default=None)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-actions", type=int, default=500)
    parser.add_argument("--output", type=Path, default=None)
    parser.add_argument("--child-build", nargs=2, metavar=("SPEC", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child_build:
        print(json.dumps(child_build(*args.child_build)))
        return
    started = time.perf_counter()
    map_path = "maps/corridors.yaml" if args.quick else "benchmarks/corridors-large.yaml"
    trials = args.trials or (20 if args.quick else 100)
    output = args.output or (RESULTS.with_name("macros-quick.md") if args.quick else RESULTS)
    big = "marked:10,150" if args.quick else "marked:40,600"
    with tempfile.TemporaryDirectory() as tmp:
        macros_path = str(Path(tmp) / "macros.npz")
        build = [_run_child(["--child-build", big, ""]), _run_child(["--child-build", map_path, macros_path])]
        for b in build:
            print(
                f"built {b['name']}: {b['states']:,} states, {b['indistinguishable_pairs']:,} pairs, "
                f"{b['seconds']:.1f} s, {b['peak_mib']:.0f} MiB",
                file=sys.stderr,
            )
        result = tables(map_path, macros_path, trials, args.seed, args.max_actions)
    text = _report(build, result, map_path, time.perf_counter() - started)
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(text, encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
