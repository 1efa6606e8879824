"""Off the grid (issue 26): localize a continuous simulated robot, started anywhere, and count the
confident wrong answers.

Each episode: a true pose uniform over the continuous free space (where the robot's disc fits) with
a uniform yaw; motion noise 5 % of the distance and 2° per turn (``MotionError``), range noise 2 cm;
optional clutter (a share of beams reading a random range). The robot answers ``localize``'s commands
through :class:`beliefloc.robots.continuous_robot.ContinuousReadingRobot` -- the same robot interface
as the line protocol -- with odometry and the blocked flag (``--protocol-1``: readings only). The
record of each episode: status, steps, cost, the true pose at the end, the position and yaw error of
the reported pose, and *confidently wrong* (declared localized, the true pose more than 1.5 cells from
the reported state's centre or more than one heading sector from its heading).

Run by hand (slow)::

    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py --maps kitchen tb3-sandbox --episodes 20
    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py --maps kitchen --episodes 20 --clutter 0.1

Only ``localize``'s strategy (best-first with replanning) is run: ``contingent`` and ``ec2-macros``
are not wired into ``localize`` yet.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from beliefloc import compile_model, load_map
from beliefloc.belief import uniform
from beliefloc.continuous.world import Clutter, ContinuousRobot, ContinuousWorld, LaserSpec, MotionError, WorldConfig
from beliefloc.model import wrap_angle
from beliefloc.pose import pose_json
from beliefloc.robots.continuous_robot import ContinuousReadingRobot
from beliefloc.robots.localize import localize
from beliefloc.robots.readings import ReadingBinner
from beliefloc.semantic_map import regions
from beliefloc.semantic_map.schema import SemanticMap

MAPS = Path(__file__).resolve().parent.parent / "maps"


def world_of(smap: SemanticMap, clutter: float, rng: np.random.Generator) -> ContinuousWorld:
    laser = LaserSpec(range_sd=0.02, range_max=12.0, range_min=0.01, mount=(0.0, 0.0, 0.0))
    config = WorldConfig(
        laser=laser,
        motion_error=MotionError(translation=0.05, rotation=0.0, per_turn=math.radians(2.0), per_metre=0.0),
        clutter=Clutter(spurious=clutter),
        robot_radius=0.1,
    )
    occupancy = smap.occupancy_map
    if occupancy is not None:
        return ContinuousWorld(occupancy, config, rng)
    image = regions.blocked_image(~smap.free, smap.grid.cell_size)  # hand-drawn: the blocked cells
    return ContinuousWorld(image, config, rng)


REAL_SCAN = {"sub_samples": 3, "yaw_samples": 3, "sigma": 0.03, "random": 0.05, "short": 0.1}
REAL_LOOK = {"sub_samples": 3, "yaw_samples": 3, "fov_edge": 3.0, "range_edge": 0.2}


def with_region_model(smap: SemanticMap) -> SemanticMap:
    """``smap`` with every Scan and Look sensor's region fields at docs/map-format.md's real-robot values."""
    sensors = {}
    for name, sensor in smap.sensors.items():
        update = REAL_SCAN if sensor.type == "scan" else REAL_LOOK if sensor.type == "look" else {}
        sensors[name] = sensor.model_copy(update=update)
    return smap.model_copy(update={"sensors": sensors})


def episode(
    name: str, seed: int, clutter: float, protocol_1: bool, max_steps: int, region: bool = False
) -> dict[str, object]:
    smap = load_map(MAPS / f"{name}.yaml")
    if region:
        smap = with_region_model(smap)
    model = compile_model(smap)
    binner = ReadingBinner(smap, model)
    rng = np.random.default_rng(seed)
    world = world_of(smap, clutter, rng)
    start = world.random_poses(1)[0]
    robot = ContinuousRobot(world, start)
    reading = ContinuousReadingRobot(robot, smap, binner, report_odometry=not protocol_1, report_blocked=not protocol_1)
    t0 = time.perf_counter()
    outcome = localize(model, uniform(model.n_states), reading, binner, max_steps=max_steps)
    seconds = time.perf_counter() - t0
    grid = model.grid
    assert grid is not None
    pose = pose_json(model, outcome.belief)
    x, y, yaw = (float(v) for v in robot.pose)
    position_error = math.hypot(pose["x"] - x, pose["y"] - y)
    yaw_error = abs(float(wrap_angle(pose["yaw"] - yaw))) if grid.headings > 1 else 0.0
    wrong = position_error > 1.5 * grid.cell_size or yaw_error > 2 * math.pi / grid.headings
    return {
        "map": name,
        "seed": seed,
        "status": outcome.status.value,
        "localized": outcome.localized,
        "probability": float(outcome.belief.max()),
        "steps": outcome.steps,
        "cost": outcome.cost,
        "recoveries": outcome.recoveries,
        "model_confidence": outcome.model_confidence,
        "true_pose": [x, y, yaw],
        "position_error": position_error,
        "yaw_error": yaw_error,
        "confidently_wrong": bool(outcome.localized and wrong),
        "wrong_if_declared": bool(wrong),
        "seconds": seconds,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--maps", nargs="+", default=["kitchen", "tb3-sandbox"])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--clutter", type=float, default=0.0, help="share of beams reading clutter")
    parser.add_argument("--protocol-1", action="store_true", help="replies carry readings only")
    parser.add_argument("--max-steps", type=int, default=60)
    parser.add_argument("--region", action="store_true", help="region models at the real-robot values")
    parser.add_argument("--json", type=Path, help="write the episode records here")
    args = parser.parse_args(argv)
    records = []
    for name in args.maps:
        rows = [
            episode(name, seed, args.clutter, args.protocol_1, args.max_steps, args.region)
            for seed in range(args.episodes)
        ]
        records.extend(rows)
        n = len(rows)
        localized = sum(bool(r["localized"]) for r in rows)
        wrong = sum(bool(r["confidently_wrong"]) for r in rows)
        statuses: dict[str, int] = {}
        for r in rows:
            statuses[str(r["status"])] = statuses.get(str(r["status"]), 0) + 1
        cost = np.mean([float(r["cost"]) for r in rows])  # type: ignore[arg-type]
        secs = np.mean([float(r["seconds"]) for r in rows])  # type: ignore[arg-type]
        print(
            f"{name}: {n} episodes, localized {localized} ({100 * localized / n:.0f} %), confidently wrong {wrong}, "
            f"mean cost {cost:.1f}, {secs:.2f} s/episode, statuses {statuses}"
        )
        declared = [r for r in rows if r["localized"]]
        if declared:
            print(f"  calibration: {len(declared)} declared at p >= 0.95, {wrong} wrong (at most 1 - p ≈ 5 % expected)")
    if args.json is not None:
        args.json.write_text(json.dumps(records, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
