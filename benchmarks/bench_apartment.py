"""One world, two questions (issue 7): localization and object search on the bundled apartment.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_apartment.py            # 200 episodes, 500 trials per setting (~1 min), to apartment.md
    python benchmarks/bench_apartment.py --quick    # 20 episodes, 20 trials (~10 s), to apartment-quick.md

A. **Localization from the knowledge base's prior** on ``maps/apartment.yaml`` (300 states): the
   start belief ``--belief prior:domains/apartment.yaml`` (the robot is usually docked in the
   kitchen: 0.9 over the kitchen's states, 0.1 over the others) against the uniform belief. The
   true start of episode ``e`` is drawn from the knowledge base's distribution, the same for both
   beliefs (``run_experiment``'s ``start_distribution``, i.e. ``simulate --start prior``), and so
   is the world's noise: paired episodes of the ``bestfirst`` planner (threshold 0.95, at most
   200 steps). Reported side by side: the first plan from each start belief (its cost, beliefs
   expanded, seconds), and over the episodes: localized, correct (the most likely state is the
   true one), mean plan time (per episode the mean over its plan calls), executed cost, steps and
   replans -- also split by whether the true start was in the kitchen (the knowledge base right)
   or not (wrong).
B. **Object search on the map against the same apartment as rectangles on a plane**:
   ``domains/apartment.yaml`` (its ``search:`` on the map: shortest paths round walls, views
   blocked by walls) against ``tests/data/map-search/apartment-plane.yaml`` (same rooms, knowledge
   base and robot; rooms as rectangles of the same sizes placed where the map has them, the
   corridor without its four doorway cells; straight-line travel, views clipped to a room).
   ``run_trials`` with ``search simulate``'s settings (knowledge 0.4, defaults, static KB, the
   domain's target, a laptop), the ``pomdp``, ``greedy`` and ``pomdp-only`` policies with the
   expectation strategy, same seeds, all targets present; then the ``pomdp`` arm with half of the
   targets absent. Reported per domain and arm: verdicts, localisation time, accuracy (each
   domain's own: a Gaussian of the path length on the map, of the straight line on the plane),
   the straight-line error in map cells for both (the plane's coordinates are the map's), how often
   the reported cell was in the target's room, steps, and wall-clock time per trial. Building
   each search space is timed too.

The tables are printed and written to ``benchmarks/results/apartment.md`` (``--quick``:
``apartment-quick.md``).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from machine import cpu_name  # benchmarks/machine.py (scripts run from benchmarks/ on sys.path)
from stats import mean, mean_or_none, sd, win_counts  # benchmarks/stats.py

from beliefloc import compile_model, load_map
from beliefloc.knowledge import load_domain, robot_start_belief
from beliefloc.model import Model
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.experiment import Arm, TrialRecord, TrialSettings, run_trials
from beliefloc.object_search.loop import Verdict
from beliefloc.object_search.settings import Metareasoning
from beliefloc.object_search.space import SearchSpace
from beliefloc.planning.best_first import plan
from beliefloc.semantic_map import room_states
from beliefloc.simulation.episode import EpisodeRecord, run_experiment, summarize
from beliefloc.simulation.strategies import EpisodeStatus

ROOT = Path(__file__).resolve().parent.parent
MAP = ROOT / "maps" / "apartment.yaml"
DOMAIN = ROOT / "domains" / "apartment.yaml"
PLANE = ROOT / "tests" / "data" / "map-search" / "apartment-plane.yaml"
RESULTS = ROOT / "benchmarks" / "results" / "apartment.md"
KB_ROOM = "kitchen"
"""Where domains/apartment.yaml's knowledge base puts the robot (its dock)."""


def first_plan(model: Model, belief: np.ndarray, repeats: int) -> dict[str, Any]:
    """The first plan from ``belief``: cost, steps, beliefs expanded, median seconds."""
    seconds = []
    for _ in range(repeats):
        started = time.perf_counter()
        result = plan(model, belief)
        seconds.append(time.perf_counter() - started)
    return {
        "cost": result.cost,
        "steps": len(result.steps),
        "expanded": result.expanded,
        "seconds": statistics.median(seconds),
    }


def _pm(values: Sequence[float], digits: int = 1) -> str:
    if not values:
        return "-"
    spread = f"±{sd(values):.{digits}f}" if len(values) > 1 else ""
    return f"{mean(values):.{digits}f}{spread}"


def localization(episodes: int, seed: int, repeats: int) -> list[str]:
    smap = load_map(MAP)
    model = compile_model(smap)
    domain = load_domain(DOMAIN)
    prior = robot_start_belief(model, domain, smap).belief  # ``--belief prior:DOMAIN`` without the CLI
    uniform = np.full(model.n_states, 1.0 / model.n_states)
    assert model.grid is not None
    kitchen = set(room_states(smap.rooms, model.grid)[KB_ROOM].tolist())
    lines = [
        "## A. Localization: the knowledge base's prior vs the uniform belief",
        "",
        f"`maps/apartment.yaml` ({model.n_states} states), `bestfirst`, {episodes} paired episodes seeded {seed}: "
        f"true starts drawn from the knowledge base's distribution ({prior[sorted(kitchen)].sum():.2f} on the "
        "kitchen's states), the same starts and noise for both start beliefs.",
        "",
        "| start belief | first plan: cost | steps | expanded | ms | localized | correct | plan ms (mean±sd) "
        "| executed cost (mean±sd) | steps | replans | cost, KB right | cost, KB wrong |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    outcomes: dict[str, list[EpisodeRecord]] = {}
    for name, belief in (("KB prior", prior), ("uniform", uniform)):
        first = first_plan(model, belief, repeats)
        records = run_experiment(
            model, ["bestfirst"], episodes=episodes, seed=seed, start_belief=belief, start_distribution=prior
        )
        outcomes[name] = records
        summary = summarize(records)["bestfirst"]
        localized = [r for r in records if r.status is EpisodeStatus.LOCALIZED]
        right = [r.cost for r in localized if model.states.index(r.start) in kitchen]
        wrong = [r.cost for r in localized if model.states.index(r.start) not in kitchen]
        plan_ms = [1000 * statistics.fmean(r.plan_seconds) for r in records if r.plan_seconds]
        lines.append(
            f"| {name} | {first['cost']:.0f} | {first['steps']} | {first['expanded']} | {1000 * first['seconds']:.1f} "
            f"| {summary.localized}/{episodes} | {summary.correct}/{episodes} | {_pm(plan_ms)} "
            f"| {_pm([r.cost for r in localized])} | {mean_or_none([r.steps for r in localized]) or 0:.1f} "
            f"| {summary.mean_replans or 0:.2f} | {_pm(right)} (n={len(right)}) | {_pm(wrong)} (n={len(wrong)}) |"
        )
        print(lines[-1], flush=True)
    starts = [[r.start for r in outcomes[name]] for name in outcomes]
    assert starts[0] == starts[1], "paired episodes must share their true starts"
    prior_costs = [r.cost for r in outcomes["KB prior"]]
    uniform_costs = [r.cost for r in outcomes["uniform"]]
    cheaper, dearer = win_counts(zip(prior_costs, uniform_costs, strict=True))
    ratio = statistics.fmean(prior_costs) / statistics.fmean(uniform_costs)
    prior_ms = [statistics.fmean(r.plan_seconds) for r in outcomes["KB prior"] if r.plan_seconds]
    uniform_ms = [statistics.fmean(r.plan_seconds) for r in outcomes["uniform"] if r.plan_seconds]
    lines += [
        "",
        f"Paired: the prior's episode was cheaper in {cheaper}, dearer in {dearer} and as costly in "
        f"{episodes - cheaper - dearer} of {episodes}; mean executed cost ratio prior / uniform {ratio:.2f}, "
        f"mean plan time ratio {statistics.fmean(prior_ms) / statistics.fmean(uniform_ms):.2f}.",
        "",
    ]
    return lines


def _arm_rows(label: str, space: SearchSpace, records: list[TrialRecord], trials: int) -> list[str]:
    rows = []
    for index, arm in enumerate(dict.fromkeys(o.arm for r in records for o in r.outcomes)):
        mine = [(r, r.outcomes[index]) for r in records]
        assert all(o.arm == arm for _, o in mine)
        verdicts = [o.verdict for _, o in mine]
        counts = "/".join(str(verdicts.count(v)) for v in (Verdict.FOUND, Verdict.NOT_FOUND, Verdict.TIME_LIMIT))
        errors, right_room = [], 0
        for r, o in mine:
            if o.reported_cell is not None and r.true_cell is not None:
                errors.append(float(np.hypot(*(space.plane[o.reported_cell] - space.plane[r.true_cell]))))
                right_room += space.rooms[space.room_of_cell[o.reported_cell]] == r.true_room
        reported = sum(1 for r, o in mine if o.reported_cell is not None and r.true_cell is not None)
        rows.append(
            f"| {label} | {arm.split('/')[0]} | {trials} | {counts} | {_pm([o.time for _, o in mine])} "
            f"| {statistics.fmean(o.accuracy for _, o in mine):.3f} | {_pm(errors, 2)} "
            f"| {right_room}/{reported} | {statistics.fmean(o.steps for _, o in mine):.1f} "
            f"| {1000 * statistics.fmean(r.seconds for r in records):.1f} |"
        )
    return rows


def object_search(trials: int, seed: int) -> list[str]:
    domains = {"map": load_domain(DOMAIN), "plane": load_domain(PLANE)}
    lines = [
        "## B. Object search: on the map vs on a plane of rectangles",
        "",
        "| domain | cells | views: mean cells | building the space, ms |",
        "| --- | ---: | ---: | ---: |",
    ]
    spaces = {}
    for label, domain in domains.items():
        built = []
        for _ in range(20):
            started = time.perf_counter()
            space = search_space(domain)
            built.append(time.perf_counter() - started)
        spaces[label] = space
        coverage = np.asarray(space.views.sum(axis=1)).ravel()[space.reachable].mean()
        lines.append(f"| {label} | {space.n_cells} | {coverage:.2f} | {1000 * statistics.median(built):.2f} |")
    lines += [
        "",
        "| domain | policy | trials | verdicts | time (mean±sd) | accuracy | straight-line error (cells) "
        "| reported in the target's room | steps | ms per trial (all arms) |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    arms = [Arm(policy, Metareasoning.EXPECTATION) for policy in ("pomdp", "greedy", "pomdp-only")]
    settings: dict[str, tuple[list[Arm], TrialSettings]] = {
        "present": (arms, TrialSettings()),
        "half absent": (arms[:1], TrialSettings(absent_fraction=0.5)),
    }
    paired_notes = []
    for what, (chosen, setting) in settings.items():
        by_domain = {}
        for label, domain in domains.items():
            records = run_trials(domain, chosen, trials=trials, seed=seed, settings=setting)
            by_domain[label] = records
            rows = _arm_rows(f"{label}, {what}", spaces[label], records, trials)
            lines += rows
            for row in rows:
                print(row, flush=True)
        same = sum(
            a.target == b.target and a.true_room == b.true_room and a.present == b.present
            for a, b in zip(by_domain["map"], by_domain["plane"], strict=True)
        )
        paired_notes.append(f"{what}: the same target in the same room in {same} of {trials} trials")
    lines += [
        "",
        "Time is in simulation units (travel 0.5 per cell, analysis 1 per view); accuracy is each domain's "
        "own (σ = 2 cells of path length on the map, of straight line on the plane); the straight-line error "
        "is measured in the map's coordinates for both. Pairing: " + "; ".join(paired_notes) + " (the map's "
        "corridor has 15 cells, the plane's 11, so a cell drawn there can consume the world's random stream "
        "differently).",
        "",
    ]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="20 episodes and 20 trials per setting")
    parser.add_argument("--episodes", type=int, default=None, help="localization episodes (default 200, quick 20)")
    parser.add_argument("--trials", type=int, default=None, help="object-search trials (default 500, quick 20)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    episodes = args.episodes or (20 if args.quick else 200)
    trials = args.trials or (20 if args.quick else 500)
    output = args.output or (RESULTS.with_name("apartment-quick.md") if args.quick else RESULTS)
    began = time.perf_counter()
    lines = [
        "# The apartment: localization from the knowledge base's prior, object search on the map",
        "",
        f"`python benchmarks/bench_apartment.py {' '.join(sys.argv[1:] if argv is None else argv)}` on "
        f"{platform.machine()} ({cpu_name()}), {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"numpy {np.__version__}.",
        "",
    ]
    lines += localization(episodes, args.seed, repeats=3 if args.quick else 10)
    lines += object_search(trials, args.seed)
    lines += [f"{time.perf_counter() - began:.0f} s in all.", ""]
    text = "\n".join(lines)
    output.write_text(text)
    print(f"written to {output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
