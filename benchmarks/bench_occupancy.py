"""Occupancy maps at real sizes: load + compile, planning from the uniform belief, macros.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_occupancy.py            # every case, a few minutes
    python benchmarks/bench_occupancy.py --quick    # the depot only

Cases, each in a fresh subprocess so that peak memory (``ru_maxrss``) is its own:

* ``maps/depot.yaml`` (Nav2's depot, 604 x 307 px at 0.05 m; cells of 0.25 m, 8 headings): load and
  compile, the Scan's ray-cast table included; then one plan from the uniform belief.
* a warehouse the size of Nav2's (1700 x 1000 px at 0.03 m: rows of shelving, pillars, a loading
  dock; generated here, seeded) with cells of 0.25 m and 8 headings, about 2·10^5 states: load and
  compile.
* ``maps/tb3-sandbox.yaml`` (the TurtleBot3 arena; cells of 0.25 m): ``macros build``.

Targets (issue 13), on a 2-core machine: depot load + compile <= 3 s, its plan <= 1 s; the
warehouse compile <= 15 s within 2 GiB; the arena's macros <= 60 s. The table is printed and written
to ``benchmarks/results/occupancy.md``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the repository root: import benchmarks.*

from benchmarks.planning.settings import peak_rss_mib, run_json_child, single_threaded  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results" / "occupancy.md"
TARGETS = {"depot_compile_s": 3.0, "depot_plan_s": 1.0, "warehouse_compile_s": 15.0, "warehouse_peak_mib": 2048.0}
TARGET_MACROS_S = 60.0


def write_warehouse(folder: Path, seed: int = 0) -> Path:
    """A synthetic warehouse of Nav2's size: 1700 x 1000 pixels at 0.03 m (51 m x 30 m), outer walls,
    four rows of shelving with cross aisles, a column of pillars and a loading dock; a semantic map
    over it with cells of 0.25 m and 8 headings. Returns the semantic map's path."""
    import numpy as np
    from PIL import Image

    rng = np.random.default_rng(seed)
    height, width = 1000, 1700  # at 0.03 m per pixel (the YAML below)
    image = np.full((height, width), 254, dtype=np.uint8)
    image[:10, :] = image[-10:, :] = 0
    image[:, :10] = image[:, -10:] = 0
    for k in range(4):  # shelving rows, 0.3 m deep, with gaps for cross aisles
        top = 200 + k * 200
        for start in range(300, 1500, 300):
            image[top : top + 10, start : start + 240] = 0
    for i in range(150, 900, 150):  # pillars of 0.3 m
        image[i : i + 10, 150:160] = 0
    image[400:600, -10:] = 205  # the dock door: unknown beyond it
    speckle = rng.random((height, width)) < 0.0005  # a SLAM map's noise
    image[speckle & (image == 254)] = 0
    Image.fromarray(image).save(folder / "warehouse.pgm")
    (folder / "warehouse.yaml").write_text(
        "image: warehouse.pgm\nmode: trinary\nresolution: 0.03\norigin: [-5.0, -3.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n",
        encoding="utf-8",
    )
    semantic = folder / "warehouse-map.yaml"
    semantic.write_text(
        """name: warehouse
occupancy: warehouse.yaml
grid: {cell_size: 0.25, headings: 8, robot_radius: 0.1}
landmarks:
  - {class: charger, x: -3.0, y: -1.5}
  - {class: door, x: 44.5, y: 12.0}
  - {class: sign, x: 20.0, y: 25.5}
actions:
  forward: {cost: 1, failure: 0.02}
  backward: {cost: 1.5, failure: 0.02}
  rotate_cw: {cost: 1, failure: 0.02}
  rotate_ccw: {cost: 1, failure: 0.02}
sensors:
  look:
    {type: look, cost: 1, classes: [charger, door, sign], false_positive: 0.01, false_negative: 0.05, range: 10}
  scan: {type: scan, cost: 1, bins: [0.5, 1.5, 3.0, 6.0], error: 0.02}
""",
        encoding="utf-8",
    )
    return semantic


def child_compile(path: str, plan: bool) -> dict[str, Any]:
    """Load and compile a map (the Scan's ray casting included); optionally plan from uniform."""
    from beliefloc.belief import uniform
    from beliefloc.semantic_map import compile_model, load_map

    start = time.perf_counter()
    smap = load_map(path)
    model = compile_model(smap)
    compile_s = time.perf_counter() - start
    result: dict[str, Any] = {
        "states": model.n_states,
        "compile_s": compile_s,
        "grid": f"{smap.grid.rows}x{smap.grid.cols}",
    }
    if plan:
        from beliefloc.planning.best_first import plan as best_first

        outcome = best_first(model, uniform(model.n_states))
        result.update(plan_s=outcome.seconds, plan_status=outcome.status.value, plan_steps=len(outcome.steps))
    result["peak_mib"] = peak_rss_mib()
    return result


def child_macros(path: str) -> dict[str, Any]:
    from beliefloc.planning.macros import build_macros
    from beliefloc.semantic_map import compile_model, load_map

    model = compile_model(load_map(path))
    start = time.perf_counter()
    table = build_macros(model)
    seconds = time.perf_counter() - start
    summary = table.summary()
    return {
        "states": model.n_states,
        "macros_s": seconds,
        "pairs": summary.get("indistinguishable_pairs"),
        "never": summary.get("never_distinguishable_pairs"),
        "peak_mib": peak_rss_mib(),
    }


def _run_child(*args: str) -> dict[str, Any]:
    single_threaded()  # the children import numpy
    result = run_json_child([sys.executable, __file__, "--child", *args], " ".join(args))
    del result["wall_s"]  # each child times what it measures itself
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the depot only")
    parser.add_argument("--output", type=Path, default=RESULTS)
    parser.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        kind, path = args.child[0], args.child[1]
        result = child_macros(path) if kind == "macros" else child_compile(path, plan=kind == "plan")
        print(json.dumps(result))
        return 0
    rows = []
    depot = _run_child("plan", str(ROOT / "maps" / "depot.yaml"))
    rows.append(
        (
            "depot: load + compile (0.25 m, 8 headings)",
            depot["states"],
            f"{depot['compile_s']:.2f} s",
            f"<= {TARGETS['depot_compile_s']:g} s",
            depot["peak_mib"],
        )
    )
    rows.append(
        (
            "depot: plan from the uniform belief",
            depot["states"],
            f"{depot['plan_s']:.3f} s ({depot['plan_status']}, {depot['plan_steps']} steps)",
            f"<= {TARGETS['depot_plan_s']:g} s",
            None,
        )
    )
    if not args.quick:
        with tempfile.TemporaryDirectory() as folder:
            warehouse = _run_child("compile", str(write_warehouse(Path(folder))))
        rows.append(
            (
                "warehouse 1700x1000 px at 0.03 m: load + compile",
                warehouse["states"],
                f"{warehouse['compile_s']:.2f} s",
                f"<= {TARGETS['warehouse_compile_s']:g} s, 2 GiB",
                warehouse["peak_mib"],
            )
        )
        macros = _run_child("macros", str(ROOT / "maps" / "tb3-sandbox.yaml"))
        rows.append(
            (
                f"tb3 sandbox: macros build ({macros['pairs']} pairs, {macros['never']} never told apart)",
                macros["states"],
                f"{macros['macros_s']:.2f} s",
                f"<= {TARGET_MACROS_S:g} s",
                macros["peak_mib"],
            )
        )
    lines = [
        "# Occupancy maps: compile, plan, macros",
        "",
        f"`python benchmarks/bench_occupancy.py{' --quick' if args.quick else ''}`, one subprocess per case "
        "(peak memory is that process's), one BLAS thread.",
        "",
        "| case | states | measured | target | peak memory |",
        "| --- | ---: | ---: | --- | ---: |",
    ]
    for case, states, measured, target, peak in rows:
        memory = "" if peak is None else f"{peak:.0f} MiB"
        lines.append(f"| {case} | {states:,} | {measured} | {target} | {memory} |")
    text = "\n".join(lines) + "\n"
    print(text)
    args.output.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
