"""Off the grid (issue 26): localize a continuous simulated robot, started anywhere, and count the
confident wrong answers.

Each episode is ``simulate --continuous``'s (:mod:`beliefloc.simulation.continuous_episode`): a true
pose uniform over the continuous free space (where the robot's disc fits) with a uniform yaw; motion
noise 5 % of the distance and 2° per turn, range noise 2 cm; optional clutter (a share of beams
reading a random range) and unmapped obstacles (``--obstacles N``: discs of 0.1-0.3 m, people or boxes,
placed afresh each episode; rays and the robot stop on them). The robot answers through
:class:`beliefloc.robots.continuous_robot.ContinuousReadingRobot` -- the robot interface of the line
protocol -- with odometry and the blocked flag (``--protocol-1``: readings only), and the episode is
``localize``'s loop with the strategy named. The record of each episode: status, steps, cost, the true
pose at the end, the position and yaw error of the reported pose, and *confidently wrong* (declared
localized, the true pose more than 1.5 cells from the reported state's centre or more than one
heading sector from its heading).

Printed per map, strategy and clutter: localized %, confidently wrong, mean cost (of the localized
episodes), statuses, how far the declared state's centre and the pose reported (the lattice's
estimate) are from the true pose, and the calibration table: among the episodes declared localized at p in a
band, the fraction wrong with its 95 % Clopper-Pearson interval, beside 1 - p.

Run by hand (slow; one process)::

    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py --maps kitchen tb3-sandbox --episodes 30
    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py --maps hallway --strategies bestfirst contingent \\
        ec2-macros --clutter 0 0.1 --episodes 30 --json offgrid.json

A long campaign (the depot's 1,800 episodes take days of one core) goes in chunks that survive being
stopped: ``--records DIR`` appends each episode, as it ends, to ``DIR/MAP-STRATEGY-cCLUTTER.jsonl``
with the commit it ran on, and skips the episodes a file already holds; ``--pool FILE...`` prints the
tables of every record in the files (the last record of an episode counts). A record keeps the
episode's actions: ``--replay FILE EPISODE`` sends them to the same episode's robot and prints, step by
step, the readings, where the robot truly is and what the filter believes -- a confidently wrong
episode, found once in hundreds, can be taken apart (planning under a time limit does not repeat)::

    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py --maps depot --strategies ec2-macros --clutter 0 \\
        --episodes 300 --max-steps 500 --time-limit 0.5 --records benchmarks/results/offgrid-records
    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py --pool benchmarks/results/offgrid-records/*.jsonl
    PYTHONPATH=$PWD python benchmarks/bench_offgrid.py \\
        --replay benchmarks/results/offgrid-records/depot-bestfirst-c0.jsonl 15
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
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
        todo = {
            strategy: [
                e for e in range(args.first, args.first + episodes) if e not in done(args, name, strategy, clutter)
            ]
            for strategy in strategies
        }
        if not any(todo.values()):
            continue
        setup = ContinuousSetup(
            smap,
            clutter=clutter,
            report_odometry=not args.protocol_1,
            lattice=args.filter == "lattice",
            full_scans=args.full_scans,
            mean_reach=args.mean_reach,
            obstacles=args.obstacles,
        )
        for strategy in strategies:
            try:  # ec2-macros builds its macro table first: a region model on an occupancy map has none
                make_strategy(StrategyName(strategy), settings, shared, np.random.default_rng(0))
            except BeliefLocError as exc:
                print(f"{name} {strategy} clutter {clutter:g}: not run: {exc}", flush=True)
                continue
            mine = []
            for e in todo[strategy]:
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
                    **({"obstacles": args.obstacles} if args.obstacles else {}),
                    "episode": e,
                    "status": record.status.value,
                    "localized": record.status.value == "localized",
                    "probability": record.max_belief,
                    "steps": record.steps,
                    "cost": record.cost,
                    **c.as_json(),
                    "seconds": time.perf_counter() - t,
                    "commit": COMMIT,
                    "actions": [step.action for step in record.trace],
                }
                mine.append(row)
                if args.records is not None:
                    with records_file(args, name, strategy, clutter).open("a", encoding="utf-8") as out:
                        out.write(json.dumps(row) + "\n")
                if args.verbose and row["confidently_wrong"]:
                    print(f"  WRONG: episode {e}: {json.dumps(row)}", flush=True)
            if mine:
                obstacles = f" obstacles {args.obstacles}" if args.obstacles else ""
                report(f"{name} {strategy} clutter {clutter:g}{obstacles}", mine)
            rows.extend(mine)
    return rows


def replay(path: Path, episode: int, args: argparse.Namespace) -> int:
    """Episode ``episode`` of the records in ``path`` again, its actions sent to its robot (see the module)."""
    from beliefloc.robots.localize import Command
    from beliefloc.simulation.continuous_episode import pose_errors, state_at

    rows = [r for r in read_records([path]) if r["episode"] == episode]
    if not rows or "actions" not in rows[0]:
        raise SystemExit(f"{path}: no record of episode {episode} with its actions")
    row = rows[0]
    if row.get("recoveries"):
        raise SystemExit(f"episode {episode} re-spread its belief {row['recoveries']} time(s): a replay cannot")
    smap = load_map(MAPS / f"{row['map']}.yaml")
    if args.region:
        smap = with_region_model(smap)
    model = compile_model(smap)
    setup = ContinuousSetup(
        smap,
        clutter=float(row["clutter"]),  # type: ignore[arg-type]
        report_odometry=not args.protocol_1,
        lattice=args.filter == "lattice",
        full_scans=args.full_scans,
        mean_reach=args.mean_reach,
        obstacles=int(row.get("obstacles", 0)),  # type: ignore[call-overload]
    )
    grid = model.grid
    assert grid is not None
    robot, reading, _ = setup.robot(model, args.seed, episode)
    binner = setup.binner(model)
    tracker = setup.belief_filter(model)
    assert tracker is not None
    tracker.start(uniform(model.n_states))
    print(f"episode {episode}: recorded {row['status']} at p = {row['probability']:.4f}, {len(row['actions'])} actions")  # type: ignore[arg-type]
    actions: list[str] = list(row["actions"])  # type: ignore[call-overload]
    for seq, name in enumerate(actions, start=1):
        action = model.action(name)
        readings = reading.act(Command(seq, action, None, None))
        observation = binner.observation(action, readings)
        report = reading.motion_report()
        tracker.predict(action, report)
        tracker.correct(action, observation, readings)
        declared, p = tracker.declared()
        truth = state_at(grid, robot.pose)
        error, yaw = pose_errors(grid, declared, robot.pose)
        moved = (
            ""
            if report is None
            else f" odometry {tuple(round(v, 3) for v in report.odometry or ())} blocked {report.blocked}"
        )
        seen = "" if observation is None else f" -> {action.observation.name(observation)} {_raw(readings)}"
        print(
            f"{seq:4d} {name}{seen}{moved} | true {tuple(round(float(v), 2) for v in robot.pose)} "
            f"({model.states.name(truth) if truth >= 0 else 'no state'}) | declared {model.states.name(declared)} "
            f"p {p:.4f}, {error:.2f} m / {math.degrees(yaw):.0f} deg off, elsewhere {tracker.elsewhere():.3g} | "
            f"the truth's promise holds {1.0 - tracker.core.elsewhere(truth) if truth >= 0 else 0.0:.3g}"
        )
    return 0


def _raw(readings: dict[str, object]) -> str:
    """The raw readings, ranges to the centimetre, as the robot sent them."""

    def short(value: object) -> object:
        if isinstance(value, float):
            return round(value, 2)
        if isinstance(value, list):
            return [short(v) for v in value]
        return value

    return " ".join(f"{name}={short(value)}" for name, value in readings.items())


def records_file(args: argparse.Namespace, name: str, strategy: str, clutter: float) -> Path:
    obstacles = f"-o{args.obstacles}" if args.obstacles else ""
    return Path(args.records) / f"{name}-{strategy}-c{clutter:g}{obstacles}.jsonl"


def done(args: argparse.Namespace, name: str, strategy: str, clutter: float) -> set[int]:
    """The episodes ``--records`` already holds for this map, strategy and clutter (none with ``--again``)."""
    if args.again or args.records is None or not records_file(args, name, strategy, clutter).exists():
        return set()
    return {int(r["episode"]) for r in read_records([records_file(args, name, strategy, clutter)])}  # type: ignore[call-overload]


def read_records(paths: list[Path]) -> list[dict[str, object]]:
    """Every episode record in the JSON-lines files, the last one of each (map, strategy, clutter, obstacles,
    episode)."""
    latest: dict[tuple[object, ...], dict[str, object]] = {}
    for path in paths:
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.strip():  # a chunk stopped mid-write leaves at most a torn last line, skipped
                try:
                    r = json.loads(line)
                except json.JSONDecodeError:
                    continue
                latest[(r["map"], r["strategy"], r["clutter"], r.get("obstacles", 0), r["episode"])] = r
    return list(latest.values())


def pool(paths: list[Path]) -> int:
    records = read_records(paths)
    cells: dict[tuple[str, str, float, int], list[dict[str, object]]] = {}
    for r in records:
        cell = (str(r["map"]), str(r["strategy"]), float(r["clutter"]), int(r.get("obstacles", 0)))  # type: ignore[arg-type, call-overload]
        cells.setdefault(cell, []).append(r)
    for (name, strategy, clutter, obstacles), rows in sorted(cells.items()):
        numbers = sorted(int(r["episode"]) for r in rows)  # type: ignore[call-overload]
        commits = sorted({str(r.get("commit", "?")) for r in rows})
        label = f"{name} {strategy} clutter {clutter:g}" + (f" obstacles {obstacles}" if obstacles else "")
        print(f"{label}: episodes {ranges(numbers)}, commits {', '.join(commits)}")
        report(label, rows)
    report("every record", records)
    return 0


def ranges(numbers: list[int]) -> str:
    """``[0, 1, 2, 5]`` as ``0-2, 5``."""
    spans: list[list[int]] = []
    for n in numbers:
        if spans and n == spans[-1][1] + 1:
            spans[-1][1] = n
        else:
            spans.append([n, n])
    return ", ".join(f"{a}-{b}" if a != b else f"{a}" for a, b in spans)


def commit() -> str:
    """The commit this runs on, ``-dirty`` when the tree has changes: a record says what code made it."""
    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True)
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--", "beliefloc"], cwd=root, capture_output=True, text=True
        )
    except OSError:
        return "unknown"
    return head.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "") if head.returncode == 0 else "unknown"


COMMIT = commit()
POSE_KEYS = ("pose_position_error", "pose_yaw_error")
"""The reported pose's errors, in records made since the pose lattice reports its own estimate."""


def report(label: str, rows: list[dict[str, object]]) -> None:
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
        f"{label}: {n} episodes, localized {len(declared)} "
        f"({100 * len(declared) / n:.0f} %), confidently wrong {wrong}, mean cost {cost}, "
        f"{secs:.2f} s/episode, statuses {statuses}",
        flush=True,
    )
    for label_of, keys in (("the state's centre", ("position_error", "yaw_error")), ("the pose reported", POSE_KEYS)):
        off = [(float(r[keys[0]]), float(r[keys[1]])) for r in declared if keys[0] in r]  # type: ignore[arg-type]
        if off:
            metres, radians = np.array(off).T
            print(
                f"  {label_of} from the true pose ({len(off)} localized): median {np.median(metres):.3f} m, "
                f"{np.degrees(np.median(radians)):.1f} deg; 95th percentile {np.percentile(metres, 95):.3f} m, "
                f"{np.degrees(np.percentile(radians, 95)):.1f} deg",
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
        "--obstacles", type=int, default=0, help="unmapped discs (people, boxes) placed afresh each episode"
    )
    parser.add_argument(
        "--mean-reach", action="store_true", help="the lattice filter declares by the mean pose's reach too"
    )
    parser.add_argument("--protocol-1", action="store_true", help="replies carry readings only")
    parser.add_argument("--max-steps", type=int, default=60)
    parser.add_argument("--time-limit", type=float, default=2.0, help="seconds per plan call")
    parser.add_argument("--region", action="store_true", help="region models at the real-robot values")
    parser.add_argument("--verbose", action="store_true", help="print every confidently wrong episode")
    parser.add_argument("--json", type=Path, help="write the episode records here")
    parser.add_argument("--records", type=Path, help="append each episode to a JSON-lines file per cell here; resume")
    parser.add_argument(
        "--again",
        action="store_true",
        help="with --records: run the episodes even where the records hold them (on newer code, say); the new "
        "records are appended and --pool counts the last record of each episode",
    )
    parser.add_argument(
        "--pool", type=Path, nargs="+", help="print the tables of these JSON-lines records, run nothing"
    )
    parser.add_argument(
        "--replay", nargs=2, metavar=("RECORDS", "EPISODE"), help="send a recorded episode's actions again"
    )
    args = parser.parse_args(argv)
    if args.pool:
        return pool(args.pool)
    if args.replay:
        return replay(Path(args.replay[0]), int(args.replay[1]), args)
    if args.records is not None:
        args.records.mkdir(parents=True, exist_ok=True)
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
