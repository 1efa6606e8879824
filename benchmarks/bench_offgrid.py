"""Off the grid (issue 26): localize a continuous simulated robot, started anywhere, and count the
confident wrong answers.

Each episode is ``simulate --continuous``'s (:mod:`beliefloc.simulation.continuous_episode`): a true
pose uniform over the continuous free space (where the robot's disc fits) with a uniform yaw; motion
noise 5 % of the distance and 2° per turn, range noise 2 cm; optional clutter (a share of beams
reading a random range). The robot answers through
:class:`beliefloc.robots.continuous_robot.ContinuousReadingRobot` -- the robot interface of the line
protocol -- with odometry and the blocked flag (``--protocol-1``: readings only), and the episode is
``localize``'s loop with the strategy named. The record of each episode: status, steps, cost, the true
pose at the end, the position and yaw error of the reported pose, and *confidently wrong* (declared
localized, the true pose more than 1.5 cells from the reported state's centre or more than one
heading sector from its heading).

Printed per map, strategy and clutter: localized %, confidently wrong, mean cost (of the localized
episodes), statuses, and the calibration table: among the episodes declared localized at p in a
band, the fraction wrong with its 95 % Clopper-Pearson interval, beside 1 - p.

Run by hand (slow; one process)::

    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py --maps kitchen tb3-sandbox --episodes 30
    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py --maps hallway --strategies bestfirst contingent \\
        ec2-macros --clutter 0 0.1 --episodes 30 --json offgrid.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from beliefloc import compile_model, load_map
from beliefloc.belief import uniform
from beliefloc.errors import BeliefLocError
from beliefloc.semantic_map.schema import SemanticMap
from beliefloc.simulation.continuous_episode import ContinuousSetup
from beliefloc.simulation.settings import StrategyName
from beliefloc.simulation.strategies import PlannerSettings, SharedWork, make_strategy

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stats import clopper_pearson

MAPS = Path(__file__).resolve().parent.parent / "maps"
REAL_SCAN = {"sub_samples": 3, "yaw_samples": 3, "sigma": 0.03, "random": 0.05, "short": 0.1}
REAL_LOOK = {"sub_samples": 3, "yaw_samples": 3, "fov_edge": 3.0, "range_edge": 0.2}
BANDS = ((0.95, 0.99), (0.99, 0.999), (0.999, 1.0 + 1e-12))
"""The calibration table's bands of the declared probability."""


def with_region_model(smap: SemanticMap) -> SemanticMap:
    """``smap`` with every Scan and Look sensor's region fields at docs/map-format.md's real-robot values."""
    sensors = {}
    for name, sensor in smap.sensors.items():
        update = REAL_SCAN if sensor.type == "scan" else REAL_LOOK if sensor.type == "look" else {}
        sensors[name] = sensor.model_copy(update=update)
    return smap.model_copy(update={"sensors": sensors})


def run_map(
    name: str, strategies: list[str], clutters: list[float], episodes: int, args: argparse.Namespace
) -> list[dict[str, object]]:
    smap = load_map(MAPS / f"{name}.yaml")
    if args.region:
        smap = with_region_model(smap)
    t0 = time.perf_counter()
    model = compile_model(smap)
    compile_seconds = time.perf_counter() - t0
    shared = SharedWork.for_model(model)
    settings = PlannerSettings(time_limit=args.time_limit)
    start = uniform(model.n_states)
    rows: list[dict[str, object]] = []
    print(f"{name}: {model.n_states} states, compiled in {compile_seconds:.1f} s", flush=True)
    for clutter in clutters:
        setup = ContinuousSetup(
            smap,
            clutter=clutter,
            report_odometry=not args.protocol_1,
            lattice=args.filter == "lattice",
            full_scans=args.full_scans,
            mean_reach=args.mean_reach,
        )
        for strategy in strategies:
            try:  # ec2-macros builds its macro table first: a region model on an occupancy map has none
                make_strategy(StrategyName(strategy), settings, shared, np.random.default_rng(0))
            except BeliefLocError as exc:
                print(f"{name} {strategy} clutter {clutter:g}: not run: {exc}", flush=True)
                continue
            mine = []
            for e in range(args.first, args.first + episodes):
                t = time.perf_counter()
                record = setup.run(
                    model,
                    strategy,
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
                    "map": name,
                    "strategy": strategy,
                    "clutter": clutter,
                    "episode": e,
                    "status": record.status.value,
                    "localized": record.status.value == "localized",
                    "probability": record.max_belief,
                    "steps": record.steps,
                    "cost": record.cost,
                    **c.as_json(),
                    "seconds": time.perf_counter() - t,
                }
                mine.append(row)
                if args.verbose and row["confidently_wrong"]:
                    print(f"  WRONG: episode {e}: {json.dumps(row)}", flush=True)
            report(name, strategy, clutter, mine)
            rows.extend(mine)
    return rows


def report(name: str, strategy: str, clutter: float, rows: list[dict[str, object]]) -> None:
    n = len(rows)
    declared = [r for r in rows if r["localized"]]
    wrong = sum(bool(r["confidently_wrong"]) for r in rows)
    statuses: dict[str, int] = {}
    for r in rows:
        statuses[str(r["status"])] = statuses.get(str(r["status"]), 0) + 1
    costs = [float(r["cost"]) for r in declared]  # type: ignore[arg-type]
    cost = f"{np.mean(costs):.1f}" if costs else "-"
    secs = np.mean([float(r["seconds"]) for r in rows])  # type: ignore[arg-type]
    print(
        f"{name} {strategy} clutter {clutter:g}: {n} episodes, localized {len(declared)} "
        f"({100 * len(declared) / n:.0f} %), confidently wrong {wrong}, mean cost {cost}, "
        f"{secs:.2f} s/episode, statuses {statuses}",
        flush=True,
    )
    for low, high in BANDS:
        band = [r for r in declared if low <= float(r["probability"]) < high]  # type: ignore[arg-type]
        if not band:
            continue
        k = sum(bool(r["confidently_wrong"]) for r in band)
        lo, hi = clopper_pearson(k, len(band))
        print(
            f"  calibration p in [{low:g}, {min(high, 1.0):g}]: {len(band)} declared, {k} wrong "
            f"({k / len(band):.3f}, 95 % CI {lo:.3f}-{hi:.3f}); 1 - p at most {1 - low:.3f}",
            flush=True,
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--maps", nargs="+", default=["kitchen", "hallway", "depot", "tb3-sandbox"])
    parser.add_argument("--strategies", nargs="+", default=["bestfirst", "contingent", "ec2-macros"])
    parser.add_argument("--clutter", nargs="+", type=float, default=[0.0, 0.1], help="shares of beams reading clutter")
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--first", type=int, default=0, help="the first episode's number")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--filter", choices=["lattice", "states"], default="lattice", help="localize's belief: pose lattice or states"
    )
    parser.add_argument("--full-scans", type=int, default=0, help="scans answered whole, with this many beams")
    parser.add_argument(
        "--mean-reach", action="store_true", help="the lattice filter declares by the mean pose's reach too"
    )
    parser.add_argument("--protocol-1", action="store_true", help="replies carry readings only")
    parser.add_argument("--max-steps", type=int, default=60)
    parser.add_argument("--time-limit", type=float, default=2.0, help="seconds per plan call")
    parser.add_argument("--region", action="store_true", help="region models at the real-robot values")
    parser.add_argument("--verbose", action="store_true", help="print every confidently wrong episode")
    parser.add_argument("--json", type=Path, help="write the episode records here")
    args = parser.parse_args(argv)
    records: list[dict[str, object]] = []
    for name in args.maps:
        records.extend(run_map(name, args.strategies, args.clutter, args.episodes, args))
    wrong = sum(bool(r["confidently_wrong"]) for r in records)
    print(f"all: {len(records)} episodes, confidently wrong {wrong}")
    if args.json is not None:
        args.json.write_text(json.dumps(records, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
