"""Planning benchmark: Colledanchise et al. 2020, Tables I and II, on generated grid worlds, with
the heuristics compared, the speed targets checked, and a plain transcription of Algorithm 1
(``baseline_algorithm1.py``) timed against ``beliefloc.planning.best_first.plan``.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_planning.py                   # 10^2, 10^3, 10^4 (100 episodes each) + 10^5 (~25 min)
    python benchmarks/bench_planning.py --quick           # 3 episodes at 10^2 and 10^3 (~30 s)
    python benchmarks/bench_planning.py --episodes 20 --big-episodes 5 --output /tmp/planning.md

Worlds are ``beliefloc generate gridworld --seen-model states`` (the authors' setting of Tables I
and II). Episode ``e`` runs on a fresh world with seed ``SeedSequence([seed, e]).generate_state(1)[0]``
(printed in the results as the "world seed"; the world is ``beliefloc generate gridworld --states N
--seed WORLD_SEED --seen-model states`` and the episode ``beliefloc simulate WORLD --seed WORLD_SEED
--max-steps 500``), from a true start drawn uniformly and the uniform start belief. Every strategy
meets the same world, start and noise (paired trials).

Each part runs in its own subprocess per size (``OPENBLAS_NUM_THREADS=1``), so that its peak
resident memory (``ru_maxrss``) is its own:

1. **episodes**: ``bestfirst``, ``random`` and (budgeted) ``uniform`` -- Tables I and II, the k-th
   plan call's time, and every replan of ``bestfirst`` timed again with an empty closed list;
2. **heuristics**: the first plan from the uniform belief with each heuristic, on the first worlds;
3. **baseline**: the first plan from the uniform belief by ``plan()`` and by the Algorithm 1
   transcription, in the same process, on the same worlds.

The table is printed and written to ``benchmarks/results/planning.md`` (``planning-quick.md`` for
``--quick``). Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results" / "planning.md"
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
STRATEGY_ORDER = ("bestfirst", "uniform", "random")
HEURISTICS = ("entropy-max-prob", "entropy-prob", "zero")
THRESHOLD = 0.95
KEY_TOLERANCE = 2.0**-31
"""Duplicate tolerance of the baseline: half of beliefloc's key resolution 2^-30."""
EXACT_MAX_STATES = 1_024
"""The baseline's exact-equality (``==``) variant also runs up to this size (10^3 is 16x16x4)."""

# The paper, by size 10^2, 10^3, 10^4 (None: "—", not run).
PAPER_SIZES = (100, 1_000, 10_000)
PAPER_PLAN_S: dict[str, tuple[float | None, ...]] = {
    "bestfirst": (0.0211, 0.7175, 6.6937),
    "uniform": (0.1424, 13.852, None),
}
PAPER_REPLANS: dict[str, tuple[float | None, ...]] = {"bestfirst": (2.58, 4.04, 9.72), "uniform": (2.02, 3.01, None)}
PAPER_COST: dict[str, tuple[float | None, ...]] = {
    "bestfirst": (29.37, 47.56, 61.09),
    "uniform": (24.91, 47.01, None),
    "random": (78.57, 97.05, 300.1),
}
PAPER_KTH_1E3 = (0.0557, 0.0161, 0.0088)
AUTHORS_CODE_HERE = (0.0023, 0.134, 9.65)
"""The authors' released code (-O3) measured on a machine like ours: mean plan time at 10^2..10^4."""

TARGET_PLAN_1E4_S = 0.05
TARGET_COST_1E4 = 61.0
TARGET_PLAN_1E5_S = 0.5
TARGET_PEAK_1E5_MIB = 2048.0


def _single_threaded() -> None:
    """One BLAS thread, set before numpy is first imported (the children import it)."""
    for name in THREAD_VARIABLES:
        os.environ[name] = "1"


def _peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------------------------
# children: each builds its worlds from the seeds, so every part sees the same worlds


def world_seed(seed: int, episode: int) -> int:
    """The seed of episode ``episode``'s world (and of its start and noise)."""
    import numpy as np

    return int(np.random.SeedSequence([seed, episode]).generate_state(1)[0])


def build_model(states: int, wseed: int, directory: Path, rotation_failure: float | None = None) -> Any:
    """``beliefloc generate gridworld --states N --seed WSEED --seen-model states`` (with
    ``--rotation-failure`` when given), loaded and compiled."""
    import numpy as np

    from beliefloc.generate import MOVE_FAILURE, SeenModel, generate_gridworld, gridworld_yaml
    from beliefloc.semantic_map import compile_model, load_map

    rotations = MOVE_FAILURE if rotation_failure is None else rotation_failure
    world = generate_gridworld(states, np.random.default_rng(wseed), SeenModel.STATES, rotation_failure=rotations)
    path = directory / f"world-{states}-{wseed}.yaml"
    path.write_text(gridworld_yaml(world, seed=wseed))
    model = compile_model(load_map(path))
    path.unlink()
    return model


def replay(model: Any, steps: Sequence[tuple[str, str | None]]) -> float:
    """``max(b)`` after applying a plan's actions and expected observations to the uniform belief."""
    from beliefloc.belief import uniform, update

    belief = uniform(model.n_states)
    for action, observation in steps:
        belief, _ = update(model, belief, action, observation)
    return float(belief.max())


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


def child_episodes(p: dict[str, Any]) -> dict[str, Any]:
    """Paired episodes of bestfirst, random and (on the first ``uniform_episodes``) budgeted uniform."""
    from beliefloc.belief import uniform
    from beliefloc.planning.successors import SuccessorEvaluator
    from beliefloc.simulation.episode import EpisodeRecord, run_experiment, summarize
    from beliefloc.simulation.strategies import PlannerSettings

    states, episodes, seed, tag = p["states"], p["episodes"], p["seed"], p["tag"]
    uniform_settings = PlannerSettings(max_expansions=p["uniform_max_expansions"], time_limit=p["uniform_time_limit"])
    all_records: list[EpisodeRecord] = []
    rows = []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench-planning-") as tmp:
        for e in range(episodes):
            wseed = world_seed(seed, e)
            model = build_model(states, wseed, Path(tmp), p.get("rotation_failure"))
            evaluator = SuccessorEvaluator(model)
            start_belief = uniform(model.n_states)
            ablation: list[dict[str, Any]] = []
            on_step = _replan_without_memory(model, evaluator, start_belief, ablation)
            common = {"episodes": 1, "seed": wseed, "start_belief": start_belief, "max_steps": p["max_steps"]}
            records = run_experiment(model, p["strategies"], settings=PlannerSettings(), on_step=on_step, **common)
            if p["uniform"] and e < p["uniform_episodes"]:
                records += run_experiment(model, ["uniform"], settings=uniform_settings, **common)
            for r in records:
                r.episode = e
                r.trace = []
            all_records += records
            rows.append(
                {
                    "episode": e,
                    "world_seed": wseed,
                    "n_states": model.n_states,
                    "start": records[0].start,
                    "strategies": {
                        r.strategy: {
                            "status": r.status,
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
            )
            parts = []
            for r in records:
                mean_plan = statistics.fmean(r.plan_seconds) if r.plan_seconds and r.strategy != "random" else None
                timing = "" if mean_plan is None else f", {r.replans} replans, {mean_plan:.4f} s/plan"
                parts.append(f"{r.strategy} {r.status} cost {r.cost:g}{timing}")
            elapsed = time.perf_counter() - started
            _say(f"  [{tag} {states:g}] episode {e + 1}/{episodes} ({elapsed:.0f} s): " + " | ".join(parts))
    return {
        "kind": "episodes",
        "states": states,
        "n_states": rows[0]["n_states"] if rows else None,
        "rows": rows,
        "summary": summarize(all_records),
        "peak_mib": _peak_rss_mib(),
        "seconds": time.perf_counter() - started,
    }


def child_heuristics(p: dict[str, Any]) -> dict[str, Any]:
    """The first plan from the uniform belief with every heuristic, each with a fresh closed list."""
    from beliefloc.belief import uniform
    from beliefloc.planning.best_first import Heuristic, plan

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
            _say(f"  [heuristics {states:g}] world {e + 1}/{worlds}: {text}")
    return {"kind": "heuristics", "states": states, "rows": rows, "peak_mib": _peak_rss_mib()}


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
    from baseline_algorithm1 import FOUND, plan_algorithm1

    from beliefloc.belief import uniform
    from beliefloc.planning.best_first import plan

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
            _say(f"  [baseline {states:g}] world {e + 1}/{worlds}: {text}")
    return {"kind": "baseline", "states": states, "rows": rows, "peak_mib": _peak_rss_mib()}


CHILDREN = {"episodes": child_episodes, "heuristics": child_heuristics, "baseline": child_baseline}


def _run_child(params: dict[str, Any]) -> dict[str, Any]:
    command = [sys.executable, str(Path(__file__).resolve()), "--child", json.dumps(params)]
    started = time.perf_counter()
    # stderr (progress) goes straight to ours
    done = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=False, env=os.environ.copy())
    if done.returncode != 0:
        raise SystemExit(f"benchmark child {params['kind']} {params['states']} failed (exit {done.returncode})")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    result["wall_s"] = time.perf_counter() - started
    return result


# ----------------------------------------------------------------------------------------------
# statistics and tables


def _mean(values: Sequence[float]) -> float | None:
    return statistics.fmean(values) if values else None


def _median(values: Sequence[float]) -> float | None:
    return statistics.median(values) if values else None


def _s(value: float | None, digits: int = 4) -> str:
    return "—" if value is None else f"{value:.{digits}f} s"


def _n(value: float | None, digits: int = 2) -> str:
    return "—" if value is None else f"{value:.{digits}f}"


def _paper(table: dict[str, tuple[float | None, ...]], strategy: str, states: int) -> float | None:
    if strategy not in table or states not in PAPER_SIZES:
        return None
    return table[strategy][PAPER_SIZES.index(states)]


def _size_label(states: int) -> str:
    exponent = len(str(states)) - 1
    return f"10^{exponent}" if states == 10**exponent else f"{states:,}"


def _runs(result: dict[str, Any], strategy: str) -> list[dict[str, Any]]:
    return [row["strategies"][strategy] for row in result["rows"] if strategy in row["strategies"]]


def table_one_two(episodes: list[dict[str, Any]]) -> list[str]:
    """Table I (plan time, replans) and Table II left (cost), ours beside the paper's."""
    lines = [
        "| size (states) | strategy | episodes | mean plan time | paper | authors' code, a machine like ours "
        "| mean replans | paper | mean cost (localized) | paper |",
        "|" + " --- |" * 10,
    ]
    for result in episodes:
        size = result["states"]
        for strategy in STRATEGY_ORDER:
            s = result["summary"].get(strategy)
            if s is None:
                continue
            planner = strategy != "random"
            time_s = s["mean_plan_seconds"] if planner else None
            replans = s["mean_replans"] if planner else None
            paper_t = _s(_paper(PAPER_PLAN_S, strategy, size)) if planner else ""
            paper_r = _n(_paper(PAPER_REPLANS, strategy, size)) if planner else ""
            authors = _s(_paper({"bestfirst": AUTHORS_CODE_HERE}, strategy, size)) if strategy == "bestfirst" else ""
            lines.append(
                f"| {_size_label(size)} ({result['n_states']:,}) | {strategy} | {s['episodes']} | {_s(time_s)} "
                f"| {paper_t} | {authors} | {_n(replans)} | {paper_r} "
                f"| {_n(s['mean_cost'])} | {_n(_paper(PAPER_COST, strategy, size))} |"
            )
    return lines


def table_outcomes(episodes: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | strategy | episodes | localized | correct | no_plan | budget_exceeded | step_limit "
        "| other | mean steps (localized) | paired cost: this / bestfirst | peak RSS (MiB) | wall (s) |",
        "|" + " --- |" * 13,
    ]
    for result in episodes:
        for strategy in [st for st in STRATEGY_ORDER if st in result["summary"]]:
            s = result["summary"][strategy]
            failures = dict(s["failures"])
            known = [failures.pop(k, 0) for k in ("no_plan", "budget_exceeded", "step_limit")]
            other = ", ".join(f"{k} {v}" for k, v in failures.items()) or "0"
            paired = "" if strategy == "bestfirst" else _paired_cost(result["rows"], strategy)
            lines.append(
                f"| {_size_label(result['states'])} | {strategy} | {s['episodes']} | {s['localized']} | {s['correct']} "
                f"| {known[0]} | {known[1]} | {known[2]} | {other} | {_n(s['mean_steps'], 1)} "
                f"| {paired} | {result['peak_mib']:.0f} | {result['wall_s']:.0f} |"
            )
    return lines


def _paired_cost(rows: list[dict[str, Any]], strategy: str) -> str:
    """Mean cost of ``strategy`` and of bestfirst over the episodes where both localized."""
    both = [
        (r["strategies"][strategy]["cost"], r["strategies"]["bestfirst"]["cost"])
        for r in rows
        if all(r["strategies"].get(st, {}).get("status") == "localized" for st in (strategy, "bestfirst"))
    ]
    return paired_means(both)


def paired_means(pairs: Sequence[tuple[float, float]], *, wins: bool = False) -> str:
    """``this / reference (n=...)``: the means of paired values; with ``wins``, how often this was lower
    (cheaper) and higher (dearer)."""
    if not pairs:
        return "—"
    text = f"{_n(_mean([a for a, _ in pairs]))} / {_n(_mean([b for _, b in pairs]))} (n={len(pairs)}"
    if wins:
        text += f"; cheaper {sum(a < b for a, b in pairs)}, dearer {sum(a > b for a, b in pairs)}"
    return text + ")"


def kth_plan_times(result: dict[str, Any], strategy: str = "bestfirst", ks: int = 3) -> list[tuple[float | None, int]]:
    """Mean over episodes of the k-th plan call's time (k = 1 is the first plan), and how many episodes had it."""
    out = []
    for k in range(1, ks + 1):
        values = [r["plan_seconds"][k - 1] for r in _runs(result, strategy) if len(r["plan_seconds"]) >= k]
        out.append((_mean(values), len(values)))
    return out


def table_kth(episodes: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | 1st (first plan) | 2nd (1st replan) | 3rd (2nd replan) | all later calls (k >= 2) | first / later |",
        "|" + " --- |" * 6,
    ]
    for result in episodes:
        cells = [f"{_s(t)} (n={n})" for t, n in kth_plan_times(result)]
        first, later = first_and_later(result)
        ratio = f"{first / later:.1f}x" if first and later else "—"
        lines.append(f"| {_size_label(result['states'])} | {' | '.join(cells)} | {_s(later)} | {ratio} |")
    lines.append(f"| paper, 10^3 | {_s(PAPER_KTH_1E3[0])} | {_s(PAPER_KTH_1E3[1])} | {_s(PAPER_KTH_1E3[2])} | | |")
    return lines


def first_and_later(result: dict[str, Any], strategy: str = "bestfirst") -> tuple[float | None, float | None]:
    """Mean time of plan call #1 and mean time of every later call (pooled over episodes)."""
    runs = _runs(result, strategy)
    first = _mean([r["plan_seconds"][0] for r in runs if r["plan_seconds"]])
    later = _mean([t for r in runs for t in r["plan_seconds"][1:]])
    return first, later


def table_ablation(episodes: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | replans | mean time, closed list kept | mean time, empty closed list | mean expanded, kept "
        "| mean expanded, empty |",
        "|" + " --- |" * 6,
    ]
    for result in episodes:
        items = [a for row in result["rows"] for a in row["ablation"]]
        lines.append(
            f"| {_size_label(result['states'])} | {len(items)} | {_s(_mean([a['memory_s'] for a in items]))} "
            f"| {_s(_mean([a['fresh_s'] for a in items]))} | {_n(_mean([a['memory_expanded'] for a in items]), 1)} "
            f"| {_n(_mean([a['fresh_expanded'] for a in items]), 1)} |"
        )
    return lines


def table_heuristics(heuristics: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | heuristic | worlds | found | budget exceeded | median expanded | mean expanded "
        "| expanded / entropy-max-prob (median) | mean first-plan cost (found) | paired cost: this / entropy-max-prob "
        "| mean time | replayed to >= 0.95 |",
        "|" + " --- |" * 12,
    ]
    for result in heuristics:
        rows = result["rows"]
        names = list(rows[0]["results"]) if rows else []
        for h in names:
            mine = [r["results"][h] for r in rows]
            found = [v for v in mine if v["status"] == "found"]
            ratios = [
                r["results"][h]["expanded"] / max(1, r["results"]["entropy-max-prob"]["expanded"])
                for r in rows
                if "entropy-max-prob" in r["results"]
            ]
            budget = sum(v["status"] == "budget_exceeded" for v in mine)
            lower = " (at least: budget hit)" if budget and h != "entropy-max-prob" else ""
            replayed = sum(v["replay"] is not None and v["replay"] >= THRESHOLD for v in found)
            lines.append(
                f"| {_size_label(result['states'])} | {h} | {len(mine)} | {len(found)} | {budget} "
                f"| {_n(_median([v['expanded'] for v in mine]), 0)} | {_n(_mean([v['expanded'] for v in mine]), 0)} "
                f"| {_n(_median(ratios), 1)}{lower} | {_n(_mean([v['cost'] for v in found]))} "
                f"| {_paired_first_cost(rows, h)} "
                f"| {_s(_mean([v['seconds'] for v in mine]))} | {replayed}/{len(found)} |"
            )
    return lines


def _paired_first_cost(rows: list[dict[str, Any]], heuristic: str) -> str:
    """Mean first-plan cost of ``heuristic`` and of the default over the worlds where both found a plan."""
    both = [
        (r["results"][heuristic]["cost"], r["results"]["entropy-max-prob"]["cost"])
        for r in rows
        if r["results"][heuristic]["cost"] is not None and r["results"]["entropy-max-prob"]["cost"] is not None
    ]
    return "" if heuristic == "entropy-max-prob" else paired_means(both)


def baseline_ratios(result: dict[str, Any], variant: str) -> list[float]:
    return [
        r[variant]["seconds"] / r["plan"]["seconds"] for r in result["rows"] if variant in r and r["plan"]["seconds"]
    ]


def table_baseline(baselines: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| size | duplicates | worlds | plan(): median time | Algorithm 1: median time | time limit hit "
        "| ratio, median (min-max) | plan(): mean expanded | Algorithm 1: mean expanded "
        "| plan(): mean cost | Algorithm 1: mean cost | same cost | both replay to >= 0.95 |",
        "|" + " --- |" * 13,
    ]
    for result in baselines:
        rows = result["rows"]
        for variant in ("tolerance", "exact"):
            mine = [r for r in rows if variant in r]
            if not mine:
                continue
            ratios = baseline_ratios(result, variant)
            hits = sum(r[variant]["status"] != "found" for r in mine)
            both = [r for r in mine if r[variant]["cost"] is not None and r["plan"]["cost"] is not None]
            same = sum(r[variant]["cost"] == r["plan"]["cost"] for r in both)
            replayed = sum(r[variant]["replay"] >= THRESHOLD and r["plan"]["replay"] >= THRESHOLD for r in both)
            spread = f"{_n(_median(ratios), 1)}x ({min(ratios):.1f}-{max(ratios):.1f})" if ratios else "—"
            label = "max abs diff <= 2^-31" if variant == "tolerance" else "exact (==)"
            lines.append(
                f"| {_size_label(result['states'])} | {label} | {len(mine)} "
                f"| {_s(_median([r['plan']['seconds'] for r in mine]))} "
                f"| {_s(_median([r[variant]['seconds'] for r in mine]))} | {hits} | {spread} "
                f"| {_n(_mean([r['plan']['expanded'] for r in mine]), 1)} "
                f"| {_n(_mean([r[variant]['expanded'] for r in mine]), 1)} "
                f"| {_n(_mean([r['plan']['cost'] for r in both]))} | {_n(_mean([r[variant]['cost'] for r in both]))} "
                f"| {same}/{len(both)} | {replayed}/{len(both)} |"
            )
    return lines


def verdict(episodes: list[dict[str, Any]], big: dict[str, Any] | None) -> list[str]:
    """The speed targets, each with the measured figure and met / NOT MET."""
    out = []

    def mark(ok: bool) -> str:
        return "met" if ok else "NOT MET"

    at_1e4 = [r for r in episodes if r["states"] == 10_000]
    if at_1e4:
        s = at_1e4[0]["summary"]["bestfirst"]
        t, c = s["mean_plan_seconds"], s["mean_cost"]
        out.append(
            f"- 10^4 states, bestfirst mean plan time {_s(t)} (target <= {TARGET_PLAN_1E4_S} s): "
            f"{mark(t is not None and t <= TARGET_PLAN_1E4_S)}"
        )
        out.append(
            f"- 10^4 states, bestfirst mean episode cost {_n(c)} over {s['localized']} localized episodes "
            f"(target <= {TARGET_COST_1E4:g}): {mark(c is not None and c <= TARGET_COST_1E4)}"
        )
    else:
        out.append("- 10^4 states: not run (targets not checked)")
    if big is not None:
        s = big["summary"]["bestfirst"]
        t = s["mean_plan_seconds"]
        out.append(
            f"- {big['n_states']:,} states ({s['episodes']} episodes), bestfirst mean plan time {_s(t)} "
            f"(target <= {TARGET_PLAN_1E5_S} s): {mark(t is not None and t <= TARGET_PLAN_1E5_S)}"
        )
        out.append(
            f"- {big['n_states']:,} states, peak RSS of its process {big['peak_mib']:.0f} MiB "
            f"(target <= {TARGET_PEAK_1E5_MIB:.0f} MiB): {mark(big['peak_mib'] <= TARGET_PEAK_1E5_MIB)}"
        )
    else:
        out.append("- 10^5 states: not run (targets not checked)")
    for result in [*episodes, *([big] if big else [])]:
        first, later = first_and_later(result)
        ok = first is not None and later is not None and later < first
        out.append(
            f"- {_size_label(result['states'])}, replans (closed list kept) cheaper than first plans: "
            f"first {_s(first)}, later {_s(later)}: {mark(ok)}"
        )
    return out


# ----------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    _single_threaded()
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--sizes", nargs="*", type=float, default=[1e2, 1e3, 1e4], help="sizes of Tables I and II")
    parser.add_argument("--episodes", type=int, help="episodes (worlds) per size (default 100; --quick: 3)")
    parser.add_argument("--quick", action="store_true", help="a smoke run: 3 episodes at 10^2 and 10^3, 2 worlds")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-steps", type=int, default=500, help="step limit of an episode")
    parser.add_argument("--uniform-time-limit", type=float, default=30.0, help="uniform: seconds per plan call")
    parser.add_argument("--uniform-max-expansions", type=int, default=200_000, help="uniform: expansions per plan")
    parser.add_argument(
        "--uniform-large-episodes",
        type=int,
        default=10,
        help="uniform runs on only this many episodes at 10^4 states and more (infeasible there; 0 skips it)",
    )
    parser.add_argument("--big-size", type=float, default=1e5, help="the size of the 10^5 target (0: skip)")
    parser.add_argument("--big-episodes", type=int, default=20, help="episodes at --big-size (bestfirst, random)")
    parser.add_argument("--heuristic-worlds", type=int, default=10, help="worlds per size for the heuristics")
    parser.add_argument("--heuristic-time-limit", type=float, default=20.0, help="seconds per heuristics plan")
    parser.add_argument("--baseline-worlds", type=int, default=10, help="worlds per size for the baseline")
    parser.add_argument("--baseline-time-limit", type=float, default=60.0, help="seconds per baseline plan")
    parser.add_argument(
        "--rotation-failure",
        type=float,
        help="worlds made with generate gridworld --rotation-failure P (0: the authors' code; default: 0.02)",
    )
    parser.add_argument("--output", type=Path, help=f"markdown to write (default {RESULTS.name}, or planning-quick.md)")
    args = parser.parse_args(argv)
    if args.child:
        params = json.loads(args.child)
        print(json.dumps(CHILDREN[params["kind"]](params)))
        return 0
    if args.quick:
        args.sizes, args.big_size = [1e2, 1e3], 0
        args.heuristic_worlds = args.baseline_worlds = 2
    args.episodes = args.episodes or (3 if args.quick else 100)
    sizes = [int(s) for s in args.sizes]
    started = time.perf_counter()
    args.load_start = os.getloadavg()[0]
    base = {"seed": args.seed, "rotation_failure": args.rotation_failure}

    episodes = []
    for states in sizes:
        uniform_episodes = args.episodes if states < 10_000 else min(args.episodes, args.uniform_large_episodes)
        _say(f"... episodes at {states:,} states ({args.episodes}; uniform on {uniform_episodes})")
        params = {
            **base,
            "kind": "episodes",
            "tag": "episodes",
            "states": states,
            "episodes": args.episodes,
            "strategies": ["bestfirst", "random"],
            "uniform": uniform_episodes > 0,
            "uniform_episodes": uniform_episodes,
            "uniform_time_limit": args.uniform_time_limit,
            "uniform_max_expansions": args.uniform_max_expansions,
            "max_steps": args.max_steps,
        }
        episodes.append(_run_child(params))
    big = None
    if args.big_size:
        _say(f"... episodes at {int(args.big_size):,} states ({args.big_episodes}, bestfirst and random)")
        big = _run_child(
            {
                **base,
                "kind": "episodes",
                "tag": "big",
                "states": int(args.big_size),
                "episodes": args.big_episodes,
                "strategies": ["bestfirst", "random"],
                "uniform": False,
                "uniform_episodes": 0,
                "uniform_time_limit": args.uniform_time_limit,
                "uniform_max_expansions": args.uniform_max_expansions,
                "max_steps": args.max_steps,
            }
        )
    heuristics = []
    for states in sizes:
        worlds = min(args.heuristic_worlds, args.episodes)
        _say(f"... heuristics at {states:,} states ({worlds} worlds)")
        heuristics.append(
            _run_child(
                {
                    **base,
                    "kind": "heuristics",
                    "states": states,
                    "worlds": worlds,
                    "heuristics": list(HEURISTICS),
                    "time_limit": args.heuristic_time_limit,
                    "max_expansions": args.uniform_max_expansions,
                }
            )
        )
    baselines = []
    for states in sizes:
        worlds = min(args.baseline_worlds, args.episodes)
        _say(f"... baseline at {states:,} states ({worlds} worlds)")
        baselines.append(
            _run_child(
                {**base, "kind": "baseline", "states": states, "worlds": worlds, "time_limit": args.baseline_time_limit}
            )
        )
    total = time.perf_counter() - started
    text = report(args, argv, episodes, big, heuristics, baselines, total)
    output = args.output or (RESULTS.with_name("planning-quick.md") if args.quick else RESULTS)
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(text)
    print(text)
    return 0


def report(
    args: argparse.Namespace,
    argv: list[str] | None,
    episodes: list[dict[str, Any]],
    big: dict[str, Any] | None,
    heuristics: list[dict[str, Any]],
    baselines: list[dict[str, Any]],
    total: float,
) -> str:
    import numpy as np
    import scipy

    machine = (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"numpy {np.__version__}, scipy {scipy.__version__}, OPENBLAS_NUM_THREADS=1"
    )
    command = " ".join(["python", "benchmarks/bench_planning.py", *(argv if argv is not None else sys.argv[1:])])
    sizes = ", ".join(_size_label(r["states"]) for r in episodes)
    uniform_note = (
        f"uniform (h = 0) has a budget of {args.uniform_time_limit:g} s and "
        f"{args.uniform_max_expansions:,} expansions per plan call and runs on the first "
        f"{args.uniform_large_episodes} episodes only at 10^4 states and more"
    )
    lines = [
        "# Planning benchmark: Colledanchise et al. 2020, Tables I and II",
        "",
        f"`{command}`",
        "",
        f"Machine: {machine}. Seed {args.seed}. Total wall time {total / 60:.1f} min; 1-minute load average "
        f"{args.load_start:.2f} at the start and {os.getloadavg()[0]:.2f} at the end (other work shares the machine).",
        "",
        f"Worlds: `beliefloc generate gridworld --seen-model states` at {sizes} states, a fresh world per "
        f"episode (world seed `SeedSequence([{args.seed}, episode]).generate_state(1)[0]`), a true start drawn "
        f"uniformly, the uniform start belief, threshold {THRESHOLD}, step limit {args.max_steps}. "
        + (
            ""
            if args.rotation_failure is None
            else f"Worlds made with `--rotation-failure {args.rotation_failure:g}`"
            + (" (the authors' code: a rotation always turns). " if args.rotation_failure == 0 else ". ")
        )
        + f"Strategies are paired (same world, start and noise). bestfirst uses the defaults "
        f"(`entropy-max-prob`, 200,000 expansions, 60 s); {uniform_note}.",
        "",
        "## Tables I and II (left): plan time, replans, cost",
        "",
        "Plan time is Table I's metric: per episode the mean over its plan calls (a budget-exceeded call "
        "included), then the mean over episodes. Replans: plan calls after the first, mean over all episodes. "
        "Cost: the sum of the executed actions' costs, mean over the episodes that localized.",
        "",
        *table_one_two(episodes + ([big] if big else [])),
        "",
        "The authors' released code (-O3, bestfirst), run on a machine like ours, needs in addition 3.9 GB and "
        "37 s of set-up at 10^4.",
        "",
        "### Outcomes",
        "",
        "Status of every episode; `correct`: the most likely state at the end is the true one. Paired cost: "
        "the mean cost of the strategy and of bestfirst over the episodes where both localized.",
        "",
        *table_outcomes(episodes + ([big] if big else [])),
        "",
        "## Table II (right): the k-th plan call's time (bestfirst)",
        "",
        "Convention: k = 1 is the first plan (from the uniform belief), k = 2 the first replan, k = 3 the "
        "second; each is the mean over the episodes that made at least k plan calls (n). The paper's "
        '"1st, 2nd, 3rd replanning times" are read the same way.',
        "",
        *table_kth(episodes + ([big] if big else [])),
        "",
        "### Does keeping the closed list make replans cheaper?",
        "",
        "Every replan of bestfirst (plan call k >= 2) was timed again from the same belief with an empty "
        "closed list (`SearchMemory`), in the same process, right after the real one.",
        "",
        *table_ablation(episodes + ([big] if big else [])),
        "",
        "## Heuristics: the first plan from the uniform belief",
        "",
        f"The first {args.heuristic_worlds} worlds of each size; every heuristic starts with an empty closed "
        f"list and has {args.heuristic_time_limit:g} s and {args.uniform_max_expansions:,} expansions. `zero` is "
        "uniform-cost search (least-cost plans). Ratios use the expansions at the budget when the budget was "
        "hit, so they are lower bounds there.",
        "",
        *table_heuristics(heuristics),
        "",
        "## Algorithm 1 as written vs `plan()`",
        "",
        f"`benchmarks/baseline_algorithm1.py` (full beliefs in nodes, a list scanned for the least f, every "
        f"successor belief materialised, duplicates by comparing beliefs with the open and closed lists) and "
        f"`beliefloc.planning.best_first.plan` (default heuristic), in the same process on the first "
        f"{args.baseline_worlds} worlds of each size, the first plan from the uniform belief. Times are the "
        f"least of three runs when a run takes under a second. The baseline has {args.baseline_time_limit:g} s; "
        "a world where it hits the limit counts with the limit as its time (the ratio is then a lower bound). "
        "Ratio = baseline time / plan() time per world.",
        "",
        *table_baseline(baselines),
        "",
        "## Targets",
        "",
        *verdict(episodes, big),
        "",
        "## Notes",
        "",
        *NOTES,
        "",
    ]
    return "\n".join(lines)


NOTES = [
    "- **p(o | a, b).** beliefloc weights an observation by the Bayes probability "
    "`Σ_j predicted_j P(o | s_j)`. The authors' code (NextNodes) skips belief entries below 1e-7 and "
    "takes `Σ_{j in support} P(o | s_j)`, *not* weighted by the belief, normalised over the observations. "
    "This changes `h = H / (max(b) p)` and hence which plans are found, their costs and replans.",
    "- **Closed list across replans.** The authors prune successors equal to a belief closed in an earlier "
    "plan call (which can make a later call fail). beliefloc keeps the successor statistics of closed "
    "beliefs (`SearchMemory`) and re-expands them without recomputing, so the search stays complete.",
    "- **Uniform-cost search.** The authors' watchdog stops it after 60 s and reports success with an empty "
    "plan; here a budget-exceeded plan call ends the episode as `budget_exceeded`, counted in the outcomes. "
    "Its plans are least-cost *in the search graph*, whose branches are observations however unlikely, so "
    "it plans for lucky observations and replans often: its executed costs are not the least.",
    "- **Worlds.** The `states` seen model is the authors' `workspace.cpp`: per class a count uniform in "
    "`[0, |S|)` of random states see it, with no geometry. Sizes are 5x5, 16x16 (1,024 states), 50x50 and "
    "158x158 (99,856 states) cells times 4 headings.",
    "- **Why the cost at 10^4 is above the paper's.** `h = H / (max(b) p)` grows like `|S| ln |S|` while "
    "`g` stays below a few hundred, so at 10^4 states the search is greedy in `h`. From a near-uniform "
    "belief, `forward` into a wall doubles `max(b)` (the states facing the wall keep their mass and "
    "receive their neighbours'), so `h` prefers driving to a wall over a Look whose observation has `p > "
    "1/sqrt(|S|)`. In worlds where one observation is common (a class seen by most states) episodes chain "
    "forwards: the costs have a median near 64 and a tail to 240. Measured alternatives on 30 worlds at "
    "10^4 (2 s / 5,000 expansions per plan): `H / p`, `H / max(b)`, `-ln max(b) / p` and `H` alone run "
    "out of budget in half or more of the episodes; the path probability instead of the last "
    "observation's costs 68.5 but plans 350x slower.",
    "- **Weighting g against h** (`--h-weight`, [planning-weight.md](planning-weight.md)). On these 100 "
    "episodes at 10^4, `f = g + w·h` costs 70.8 with w = 0.1 and 69.6 with w = 0.05 (74.2 at w = 1) for "
    "6-14x the planning time. The authors' unweighted `p` (the first note) instead of the Bayes one, "
    "tried on 30 worlds at 10^4, raised the mean cost from 73 to 107 (median 64 to 61); their whole Look "
    "successor (entries below 1e-7 dropped from the successor beliefs as well), in worlds whose rotations "
    "always turn, 86 against our 60 on the same 30 worlds.",
    "- **The authors' duplicate rule.** Their `Node ==` holds when every entry is within 0.001, the "
    "action and `g` are the same; it is checked when a successor is pushed, against the open list and a "
    "closed list kept across replans, so at 10^4 states (entries near 1e-4) diffuse beliefs reached by "
    "the same action at the same cost are merged. Tried on 30 worlds at 10^4: the same mean cost (73.2 vs "
    "73.2, 5.4 vs 5.5 replans), and plan calls 3-4x slower (replans 0.021 s, first plans 0.020 s: no cheaper), "
    "because greedy search seldom reaches the "
    "merged beliefs. Dropping the costliest 10 % of our 100 episodes (as episodes the authors' code never "
    "finished would be dropped) still leaves 64.3.",
    "- **The authors' main loop** (run_comparison.cpp) compares the belief after a Look with the plan's "
    "entry by entry within 0.001 and, after a move, adopts the plan's expected belief. With our planner "
    "on the same 30 worlds at 10^4 it gives the same episodes (cost 73.2, 5.5 replans, all correct): "
    "plans expect rare observations, whose beliefs differ from the real ones by more than 0.001.",
    "- **Rotations.** In the authors' transition model (gridworld_triangles.cpp) a rotation succeeds with "
    "probability 0.98 and has no other outcome, so after normalising, and in their simulated robot, it "
    "always turns; here rotations fail (stay) with 0.02, as the paper's text says of every actuation "
    "action. It matters: on the same 100 episodes per size, worlds made with `--rotation-failure 0` cost "
    "28.8 / 44.7 / 68.4 at 10^2 / 10^3 / 10^4 states (`python benchmarks/bench_planning.py "
    "--rotation-failure 0`, [planning-authors-rotations.md](planning-authors-rotations.md)) against 30.4 "
    "/ 47.1 / 74.2 here. A rotation that may fail spreads the belief over headings, which raises `h`, so "
    "the plans turn less and drive more: per episode at 10^4 (the first 40), 0.8 rotations and 5.5 "
    "forward or backward moves, against 2.9 and 2.6 when rotations always turn.",
    "- **The authors' random numbers.** Their `generateRandomNumber` and `draw` (utils.cpp) seed a new "
    "`std::default_random_engine` from the system clock on every call, so consecutive draws in the loops "
    "that scatter the seen states (and the sensor noise) come from nearly evenly spaced seeds: their "
    "worlds are not the independent uniform draws ours are. Costs at 10^4 are therefore not directly "
    "comparable.",
    "- **Machine.** The paper's times are from an i5-6200U laptop and C++; ours are Python on a shared "
    "2-core machine. Compare ratios and orders of magnitude, not digits.",
]


if __name__ == "__main__":
    sys.exit(main())
