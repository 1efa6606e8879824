"""The parts of the planning benchmark, each run in a child process per size (``python -m
benchmarks.planning --child PARAMS``) so that its peak memory is its own: paired episodes, the heuristics'
first plans, and ``plan()`` against the Algorithm 1 transcription. Each child builds its worlds from the
seeds, so every part sees the same worlds.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks.stats import mean_or_none

from .settings import EXACT_MAX_STATES, KEY_TOLERANCE, THRESHOLD, peak_rss_mib, run_json_child, say
from .worlds import build_model, replay, world_seed


def _replan_without_memory(model: Any, evaluator: Any, start: Any, out: list[dict[str, Any]]) -> Any:
    """An ``on_step`` hook: after each replan of bestfirst, plan again from the same belief with an
    empty closed list, and record both (time, expansions) in ``out``."""
    from beliefloc.planning.best_first import plan

    before = {"belief": start}

    def on_step(record: Any, step: Any, belief: Any) -> None:
        if record.strategy != "bestfirst":
            return
        if step.plan is not None and record.steps > 1:
            fresh = plan(model, before["belief"], evaluator=evaluator)
            out.append(
                {
                    "memory_s": step.plan.seconds,
                    "memory_expanded": step.plan.expanded,
                    "fresh_s": fresh.seconds,
                    "fresh_expanded": fresh.expanded,
                }
            )
        before["belief"] = belief

    return on_step


@dataclass(frozen=True)
class WorldEpisodes:
    """The episodes part as a sweep (:mod:`beliefloc.simulation.sweep`): unit ``e`` builds world ``e`` from its
    seed and runs its paired episodes, so the worlds can run on several worker processes
    (``--workers``) with the same results. Picklable: its parameters only."""

    p: dict[str, Any]

    def runner(self) -> Callable[[int], dict[str, Any]]:
        return lambda e: _world_episodes(self.p, e)


def _world_episodes(p: dict[str, Any], e: int) -> dict[str, Any]:
    """Episode ``e`` of every strategy on world ``e``: its row of the tables and its records' JSON."""
    from beliefloc.belief import uniform
    from beliefloc.planning.successors import SuccessorEvaluator
    from beliefloc.simulation.episode import run_experiment
    from beliefloc.simulation.strategies import PlannerSettings

    # the paper's protocol: a plan call out of budget ends the episode (anytime=False; issue 28's
    # anytime robots act on partial plans instead), so Tables I-II count it as budget_exceeded
    uniform_settings = PlannerSettings(
        max_expansions=p["uniform_max_expansions"], time_limit=p["uniform_time_limit"], anytime=False
    )
    with tempfile.TemporaryDirectory(prefix="bench-planning-") as tmp:
        wseed = world_seed(p["seed"], e)
        model = build_model(p["states"], wseed, Path(tmp), p.get("rotation_failure"))
    evaluator = SuccessorEvaluator(model)
    start_belief = uniform(model.n_states)
    ablation: list[dict[str, Any]] = []
    on_step = _replan_without_memory(model, evaluator, start_belief, ablation)
    common = {"episodes": 1, "seed": wseed, "start_belief": start_belief, "max_steps": p["max_steps"]}
    paper = PlannerSettings(anytime=False)
    records = run_experiment(model, p["strategies"], settings=paper, on_step=on_step, **common)
    if p["uniform"] and e < p["uniform_episodes"]:
        records += run_experiment(model, ["uniform"], settings=uniform_settings, **common)
    for r in records:
        r.episode = e
    row = {
        "episode": e,
        "world_seed": wseed,
        "n_states": model.n_states,
        "start": records[0].start,
        "strategies": {
            r.strategy: {
                "status": r.status.value,
                "correct": r.correct,
                "cost": r.cost,
                "steps": r.steps,
                "replans": r.replans,
                "plan_seconds": r.plan_seconds,
            }
            for r in records
        },
        "ablation": ablation,
    }
    return {"row": row, "records": [r.as_json() for r in records]}


def child_episodes(p: dict[str, Any]) -> dict[str, Any]:
    """Paired episodes of bestfirst, random and (on the first ``uniform_episodes``) budgeted uniform,
    a world per episode, on ``p["workers"]`` processes (1: this one; more: plan times then share the
    cores, so Table I's times are measured with one)."""
    from beliefloc.simulation.episode import EpisodeRecord, summarize
    from beliefloc.simulation.sweep import backend, in_order

    states, episodes, tag = p["states"], p["episodes"], p["tag"]
    all_records: list[EpisodeRecord] = []
    rows = []
    started = time.perf_counter()
    runs_on = backend(p.get("workers", 1))
    indices = list(range(episodes))
    try:
        for e, result in in_order(runs_on.run(WorldEpisodes(p), indices), indices):
            records = [EpisodeRecord.from_json(data) for data in result["records"]]
            all_records += records
            rows.append(result["row"])
            parts = []
            for r in records:
                mean_plan = mean_or_none(r.plan_seconds) if r.strategy != "random" else None
                timing = "" if mean_plan is None else f", {r.replans} replans, {mean_plan:.4f} s/plan"
                parts.append(f"{r.strategy} {r.status.value} cost {r.cost:g}{timing}")
            elapsed = time.perf_counter() - started
            say(f"  [{tag} {states:g}] episode {e + 1}/{episodes} ({elapsed:.0f} s): " + " | ".join(parts))
    finally:
        runs_on.close()
    return {
        "kind": "episodes",
        "states": states,
        "n_states": rows[0]["n_states"] if rows else None,
        "rows": rows,
        "summary": {name: summary.as_json() for name, summary in summarize(all_records).items()},
        "peak_mib": peak_rss_mib(),
        "seconds": time.perf_counter() - started,
    }


def child_heuristics(p: dict[str, Any]) -> dict[str, Any]:
    """The first plan from the uniform belief with every heuristic, each with a fresh closed list."""
    from beliefloc.belief import uniform
    from beliefloc.planning.best_first import plan
    from beliefloc.planning.settings import Heuristic

    states, worlds, seed = p["states"], p["worlds"], p["seed"]
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-planning-") as tmp:
        for e in range(worlds):
            wseed = world_seed(seed, e)
            model = build_model(states, wseed, Path(tmp), p.get("rotation_failure"))
            results = {}
            for name in p["heuristics"]:
                r = plan(
                    model,
                    uniform(model.n_states),
                    heuristic=Heuristic(name),
                    max_expansions=p["max_expansions"],
                    time_limit=p["time_limit"],
                )
                results[name] = {
                    "status": r.status.value,
                    "expanded": r.expanded,
                    "generated": r.generated,
                    "seconds": r.seconds,
                    "cost": r.cost if r.found else None,
                    "replay": replay(model, [(s.action, s.observation) for s in r.steps]) if r.found else None,
                }
            rows.append({"episode": e, "world_seed": wseed, "n_states": model.n_states, "results": results})
            text = " | ".join(f"{h} {v['status']} {v['expanded']} exp {v['seconds']:.3f} s" for h, v in results.items())
            say(f"  [heuristics {states:g}] world {e + 1}/{worlds}: {text}")
    return {"kind": "heuristics", "states": states, "rows": rows, "peak_mib": peak_rss_mib()}


def _best_of(run: Callable[[], Any], seconds: Callable[[Any], float]) -> tuple[Any, float]:
    """Run once; if that took under a second, twice more, and keep the least time (same result)."""
    result = run()
    best = seconds(result)
    if best < 1.0:
        for _ in range(2):
            best = min(best, seconds(run()))
    return result, best


def child_baseline(p: dict[str, Any]) -> dict[str, Any]:
    """The first plan from the uniform belief: ``plan()`` and the Algorithm 1 transcription, side by side."""
    from beliefloc.belief import uniform
    from beliefloc.planning.best_first import plan
    from benchmarks.baseline_algorithm1 import FOUND, plan_algorithm1

    states, worlds, seed, limit = p["states"], p["worlds"], p["seed"], p["time_limit"]
    variants = {"tolerance": KEY_TOLERANCE}
    if states <= EXACT_MAX_STATES:
        variants["exact"] = 0.0
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-planning-") as tmp:
        for e in range(worlds):
            wseed = world_seed(seed, e)
            model = build_model(states, wseed, Path(tmp), p.get("rotation_failure"))
            start = uniform(model.n_states)
            ours, ours_s = _best_of(lambda m=model, b=start: plan(m, b), lambda r: float(r.seconds))
            row: dict[str, Any] = {
                "episode": e,
                "world_seed": wseed,
                "plan": {
                    "status": ours.status.value,
                    "seconds": ours_s,
                    "expanded": ours.expanded,
                    "cost": ours.cost if ours.found else None,
                    "replay": replay(model, [(s.action, s.observation) for s in ours.steps]) if ours.found else None,
                },
            }
            for name, tolerance in variants.items():
                base, base_s = _best_of(
                    lambda m=model, b=start, t=tolerance: plan_algorithm1(
                        m, b, threshold=THRESHOLD, time_limit=limit, tolerance=t
                    ),
                    lambda r: float(r.seconds),
                )
                found = base.status == FOUND
                row[name] = {
                    "status": base.status,
                    "seconds": base_s,
                    "expanded": base.expanded,
                    "cost": base.cost if found else None,
                    "replay": replay(model, base.plan) if found else None,
                }
            rows.append(row)
            text = " | ".join(
                f"{k} {row[k]['status']} {row[k]['seconds']:.4f} s {row[k]['expanded']} exp"
                for k in ("plan", *variants)
            )
            say(f"  [baseline {states:g}] world {e + 1}/{worlds}: {text}")
    return {"kind": "baseline", "states": states, "rows": rows, "peak_mib": peak_rss_mib()}


CHILDREN = {"episodes": child_episodes, "heuristics": child_heuristics, "baseline": child_baseline}


def run_child(params: dict[str, Any]) -> dict[str, Any]:
    """Run one part in a fresh ``python -m benchmarks.planning --child`` at the repository root; its
    result, with the wall-clock seconds it took."""
    command = [sys.executable, "-m", "benchmarks.planning", "--child", json.dumps(params)]
    return run_json_child(command, f"{params['kind']} {params['states']}")
