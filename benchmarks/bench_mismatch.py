"""Robots unlike the map's model (issue 26): does beliefloc stay right when the robot is not what it assumes?

``bench_offgrid.py``'s robot has exactly the noise the lattice filter assumes (motion 5 % and 2° a turn,
range noise 2 cm). A real robot does not read the map's fields: its lidar is noisier, its wheels slip and
drift, its laser is mounted a little turned, people stand in its way. Each *variant* below changes the
continuous simulated robot only -- the map, the model and the filter stay as they are -- and runs the
same seeded episodes (``simulate --continuous``'s, through ``localize``'s loop) as the plain robot:

==========  ===========================================================================================
variant     the robot
==========  ===========================================================================================
plain       as ``bench_offgrid.py``'s
range5      range noise 5 cm (the filter assumes 2-4 cm)
range10     range noise 10 cm
motion10    motion noise 10 % of a move and 5° a turn (the filter assumes 5 % and 2°)
drift       odometry reads 3 % long and turns 0.03 rad per metre driven (a worn wheel)
drift10     odometry reads 10 % long, turns 0.1 rad per metre and 5 % too far a turn
dropout     10 % of the beams that hit something read nothing (dark or glancing surfaces)
mount       the laser mounted turned 3° on the base
people      unmapped discs (``--obstacles``' people and boxes) besides: see ``--people``
==========  ===========================================================================================

Printed per variant: episodes localized, *confidently wrong* (declared, the truth beyond 1.5 cells or a
heading sector), the other statuses, the median actions, and the lowest model confidence of a
declaration. Run by hand (about 3 s an episode on tb3-sandbox, 25 s on the depot)::

    PYTHONPATH=$PWD python benchmarks/bench_mismatch.py --map tb3-sandbox --episodes 20
    PYTHONPATH=$PWD python benchmarks/bench_mismatch.py --map depot --variants people drift10 range10 \\
        --episodes 10 --people 8 --json depot-mismatch.jsonl
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from beliefloc import compile_model, load_map
from beliefloc.belief import uniform
from beliefloc.continuous.world import Drift, LaserSpec, WorldConfig
from beliefloc.simulation.continuous_episode import ContinuousSetup
from beliefloc.simulation.strategies import PlannerSettings, SharedWork

MAPS = Path(__file__).resolve().parent.parent / "maps"
VARIANTS: dict[str, dict[str, dict[str, Any]]] = {
    "plain": {},
    "range5": {"laser": {"range_sd": 0.05}},
    "range10": {"laser": {"range_sd": 0.10}},
    "motion10": {"motion": {"translation": 0.10, "per_turn": math.radians(5.0)}},
    "drift": {"drift": {"scale": 0.03, "yaw_rate": 0.03}},
    "drift10": {"drift": {"scale": 0.10, "yaw_rate": 0.10, "turn_scale": 0.05}},
    "dropout": {"clutter": {"dropout": 0.1}},
    "mount": {"laser": {"mount": (0.0, 0.0, math.radians(3.0))}},
    "people": {},
}
"""Each variant's changes to the plain robot's :class:`~beliefloc.continuous.world.WorldConfig` parts."""


@dataclasses.dataclass(frozen=True)
class UnlikeSetup(ContinuousSetup):
    """``simulate --continuous``'s robot with one variant's changes to its world."""

    variant: str = "plain"

    @property
    def config(self) -> WorldConfig:
        plain = super().config
        change = VARIANTS[self.variant]
        laser: LaserSpec = dataclasses.replace(plain.laser, **change.get("laser", {}))
        return dataclasses.replace(
            plain,
            laser=laser,
            motion_error=dataclasses.replace(plain.motion_error, **change.get("motion", {})),
            clutter=dataclasses.replace(plain.clutter, **change.get("clutter", {})),
            drift=Drift(**change.get("drift", {})),
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--map", default="tb3-sandbox")
    parser.add_argument("--variants", nargs="+", default=[v for v in VARIANTS if v != "people"], choices=VARIANTS)
    parser.add_argument("--strategy", default="ec2-macros")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--people", type=int, default=3, help="unmapped discs of the people variant")
    parser.add_argument("--max-steps", type=int, default=300)
    parser.add_argument("--time-limit", type=float, default=0.5, help="seconds per plan call")
    parser.add_argument("--json", type=Path, help="append each episode's record here (JSON lines)")
    args = parser.parse_args(argv)
    smap = load_map(MAPS / f"{args.map}.yaml")
    model = compile_model(smap)
    shared = SharedWork.for_model(model)
    settings = PlannerSettings(time_limit=args.time_limit)
    start = uniform(model.n_states)
    wrong_total = 0
    for variant in args.variants:
        setup = UnlikeSetup(smap, variant=variant, obstacles=args.people if variant == "people" else 0)
        rows = []
        for e in range(args.first, args.first + args.episodes):
            t = time.perf_counter()
            record = setup.run(
                model,
                args.strategy,
                seed=args.seed,
                episode=e,
                start_belief=start,
                settings=settings,
                shared=shared,
                max_steps=args.max_steps,
            )
            c = record.continuous
            assert c is not None
            row = {
                "map": args.map,
                "variant": variant,
                "strategy": args.strategy,
                "episode": e,
                "status": record.status.value,
                "probability": record.max_belief,
                "steps": record.steps,
                **c.as_json(),
                "seconds": time.perf_counter() - t,
            }
            rows.append(row)
            if args.json is not None:
                with args.json.open("a", encoding="utf-8") as out:
                    out.write(json.dumps(row) + "\n")
        declared = [r for r in rows if r["status"] == "localized"]
        wrong = sum(bool(r["confidently_wrong"]) for r in rows)
        wrong_total += wrong
        statuses = Counter(str(r["status"]) for r in rows)
        lowest = min((float(r["model_confidence"]) for r in declared), default=math.nan)
        print(
            f"{args.map} {variant}: {len(rows)} episodes, localized {len(declared)}, confidently wrong {wrong}, "
            f"statuses {dict(statuses)}, median actions {np.median([r['steps'] for r in rows]):.0f}, "
            f"lowest model confidence declared {lowest:.2f}",
            flush=True,
        )
    print(f"all variants: confidently wrong {wrong_total}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
