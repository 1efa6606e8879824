"""Belief pictures at real sizes: drawing and writing a PNG (and an SVG) of a large belief.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_pictures.py            # every case, well under a minute
    python benchmarks/bench_pictures.py --quick    # one repetition each

Cases (issue 14), on a 2-core machine:

* a generated grid world (``beliefloc.simulation.gridworld``, Sec. VII-A) of about 10^5 states, with a belief
  that gives every state some probability (the worst case: every triangle drawn) -- target <= 1 s;
* a warehouse the size of Nav2's (``bench_occupancy.write_warehouse``: 1700 x 1000 px at 0.03 m,
  cells of 0.25 m, 8 headings, about 1.7·10^5 states) with the uniform belief: the occupancy image,
  rooms-free, every triangle -- target <= 3 s;
* ``maps/depot.yaml`` (49,592 states), for scale;
* ``simulate --record``: a 60-frame GIF of a kitchen episode (``-s random --threshold 1.0
  --max-steps 59``: 59 steps to the step limit, 60 frames), the command end to end in a fresh
  process (start-up and importing matplotlib included), its GIF checked -- target <= 15 s.

A case is timed from the compiled model and belief to the file written
(:func:`beliefloc.render.picture_belief.belief_figure` and
:func:`beliefloc.render.figures.save_figure`): the median of the repetitions in a process that has
already drawn once (matplotlib imported, its fonts cached); the first drawing of the process, which
pays for importing matplotlib, is reported beside it. The table is printed and written to
``benchmarks/results/pictures.md``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_occupancy import write_warehouse  # noqa: E402
from machine import cpu_name  # noqa: E402

from beliefloc.model import Model  # noqa: E402
from beliefloc.semantic_map import SemanticMap, compile_model, load_map  # noqa: E402
from beliefloc.simulation.gridworld import generate_gridworld, gridworld_yaml  # noqa: E402
from beliefloc.simulation.settings import SeenModel  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results" / "pictures.md"
TARGETS = {"gridworld": 1.0, "warehouse": 3.0}
GRIDWORLD_STATES = 100_000
RECORD_FRAMES = 60
TARGET_RECORD_S = 15.0
RECORD_EPISODE = ["-s", "random", "--threshold", "1.0", "--max-steps", str(RECORD_FRAMES - 1), "--seed", "0"]


def _time_picture(model: Model, belief: np.ndarray, smap: SemanticMap | None, path: Path) -> float:
    from beliefloc.render.figures import save_figure
    from beliefloc.render.picture_belief import belief_figure

    start = time.perf_counter()
    with belief_figure(model, belief, smap=smap) as fig:
        save_figure(fig, path)
    return time.perf_counter() - start


def _case(
    name: str, load: Callable[[Path], tuple[Model, np.ndarray, SemanticMap | None]], repeats: int, folder: Path
) -> dict[str, object]:
    model, belief, smap = load(folder)
    png, svg = folder / f"{name}.png", folder / f"{name}.svg"
    png_s = statistics.median(_time_picture(model, belief, smap, png) for _ in range(repeats))
    svg_s = statistics.median(_time_picture(model, belief, smap, svg) for _ in range(repeats))
    return {
        "states": model.n_states,
        "drawn": int(np.count_nonzero(belief)),
        "png_s": png_s,
        "png_kib": png.stat().st_size / 1024,
        "svg_s": svg_s,
        "svg_kib": svg.stat().st_size / 1024,
    }


def _gridworld(folder: Path) -> tuple[Model, np.ndarray, SemanticMap | None]:
    world = generate_gridworld(GRIDWORLD_STATES, np.random.default_rng(1), SeenModel.OBJECTS)
    path = folder / "gridworld.yaml"
    path.write_text(gridworld_yaml(world, seed=1), encoding="utf-8")
    smap = load_map(path)
    model = compile_model(smap)
    belief = np.random.default_rng(0).random(model.n_states) ** 4 + 1e-6  # every state some probability
    return model, belief / belief.sum(), smap


def _warehouse(folder: Path) -> tuple[Model, np.ndarray, SemanticMap | None]:
    smap = load_map(write_warehouse(folder))
    model = compile_model(smap)
    return model, np.full(model.n_states, 1.0 / model.n_states), smap


def _depot(folder: Path) -> tuple[Model, np.ndarray, SemanticMap | None]:
    smap = load_map(ROOT / "maps" / "depot.yaml")
    model = compile_model(smap)
    return model, np.full(model.n_states, 1.0 / model.n_states), smap


def _record_gif(folder: Path) -> tuple[float, float]:
    """Seconds of ``beliefloc simulate maps/kitchen.yaml RECORD_EPISODE --record episode.gif`` in a
    fresh process, and the GIF's KiB; the GIF must hold RECORD_FRAMES frames of one size."""
    from PIL import Image, ImageSequence

    gif = folder / "episode.gif"
    gif.unlink(missing_ok=True)
    command = [sys.executable, "-m", "beliefloc", "simulate", str(ROOT / "maps" / "kitchen.yaml"), *RECORD_EPISODE]
    start = time.perf_counter()
    done = subprocess.run([*command, "--record", str(gif)], capture_output=True, text=True, cwd=ROOT)
    seconds = time.perf_counter() - start
    if done.returncode not in (0, 1):  # 1: the episode ends at its step limit, not localized
        raise RuntimeError(f"simulate --record failed ({done.returncode}): {done.stderr}")
    with Image.open(gif) as image:
        sizes = [frame.size for frame in ImageSequence.Iterator(image)]
    if len(sizes) != RECORD_FRAMES or len(set(sizes)) != 1:
        raise RuntimeError(f"{gif}: {len(sizes)} frames of sizes {set(sizes)}, expected {RECORD_FRAMES} of one size")
    return seconds, gif.stat().st_size / 1024


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repetition per case")
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else 3
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        model, belief, smap = _depot(folder)
        first_s = _time_picture(model, belief, smap, folder / "first.png")  # imports matplotlib
        cases = [
            (f"grid world of ~10^{round(np.log10(GRIDWORLD_STATES))} states, every state > 0", "gridworld", _gridworld),
            ("warehouse 1700x1000 px at 0.03 m, uniform", "warehouse", _warehouse),
            ("maps/depot.yaml, uniform", "depot", _depot),
        ]
        rows = []
        for label, key, load in cases:
            result = _case(key, load, repeats, folder)
            target = f"<= {TARGETS[key]:g} s" if key in TARGETS else ""
            rows.append((label, result, target))
        record_s = statistics.median(_record_gif(folder)[0] for _ in range(repeats))
        record_kib = (folder / "episode.gif").stat().st_size / 1024
    lines = [
        "# Belief pictures: draw and write",
        "",
        "`python benchmarks/bench_pictures.py`: `belief_figure` + `save_figure`, from the compiled model and the",
        f"belief to the file; median of {repeats} in a warm process (matplotlib imported).",
        "",
        "| case | states | triangles drawn | PNG | target | PNG size | SVG | SVG size |",
        "| --- | ---: | ---: | ---: | --- | ---: | ---: | ---: |",
    ]
    for label, r, target in rows:
        lines.append(
            f"| {label} | {r['states']:,} | {r['drawn']:,} | {r['png_s']:.2f} s | {target} | "
            f"{r['png_kib']:.0f} KiB | {r['svg_s']:.2f} s | {r['svg_kib']:.0f} KiB |"
        )
    lines.append(
        f"| `simulate --record`: kitchen episode, {RECORD_FRAMES}-frame GIF, end to end in a fresh process "
        f"| 36 | 36 a frame | {record_s:.2f} s | <= {TARGET_RECORD_S:g} s | {record_kib:.0f} KiB (GIF) | | |"
    )
    lines += [
        "",
        f"`simulate --record`: `beliefloc simulate maps/kitchen.yaml {' '.join(RECORD_EPISODE)} --record "
        "episode.gif` (59 steps to the step limit: 60 frames), median of the repetitions.",
        "",
        f"The process's first picture (the depot, importing matplotlib): {first_s:.2f} s.",
        "Above 20,000 triangles the triangles are rasterized inside the SVG (`RASTERIZE_POLYGONS`).",
        "",
        f"Machine: {cpu_name()}, Python {sys.version.split()[0]}.",
    ]
    text = "\n".join(lines) + "\n"
    print(text)
    args.output.write_text(text, encoding="utf-8")
    failed = [label for label, r, target in rows if target and r["png_s"] > TARGETS[_key(label)]]
    return 1 if failed or record_s > TARGET_RECORD_S else 0


def _key(label: str) -> str:
    return "gridworld" if label.startswith("grid world") else "warehouse"


if __name__ == "__main__":
    raise SystemExit(main())
