"""Plans a waiting robot can use on real floors (issue 28): today's best-first strategy against the
anytime one, side by side in one run, on Nav2's floors.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_real_floors.py                      # 50 episodes a map and planner
    python benchmarks/bench_real_floors.py --episodes 10 --today-episodes 5 --jobs 2
    python benchmarks/bench_real_floors.py --quick              # 3 episodes a map (a smoke run)

**Planners** (three, side by side). ``today``: the best-first strategy as it was before issue 28
-- the library's default budget (200,000 expansions, 60 s a plan call) and an episode that gives up
when a plan call runs out of it (``PlannerSettings(anytime=False)``). ``anytime``: the same search
with ``--budget`` seconds a call (0.4 by default), doing the first step of the best partial plan by
its estimate when the budget runs out (``PlanResult.partial``, ``PlannerSettings.partial_steps``)
and planning again after it. ``anytime-grow``: the same, but after a call out of budget the next
call gets twice the seconds, up to ``--max-budget`` (0.8; ``PlannerSettings.max_time_limit``).

**Maps.** A name with ``+region`` (e.g. ``tb3-sandbox+region``) is the map with region models on
every look and scan sensor (:data:`REGION_FIELDS`, the values docs/map-format.md gives for a real
robot). ``maps/tb3-sandbox.yaml`` (2,088 states), ``maps/depot.yaml`` (49,592 states, six objects)
and ``maps/depot-corridor.yaml`` (24,796 states, a three-beam scan and one object: the
information-poor floor). Episode ``e`` of a map starts both planners at the same true state with the
same noise (``episode_rngs(--seed, e)``, paired trials), from the uniform belief, threshold 0.95,
at most ``--max-steps`` (200) actions. Each map and planner runs in a child process of its own
(``--child``); ``OPENBLAS_NUM_THREADS=1``.

**Columns.** Per map and planner: episodes; the median and the worst plan call (seconds, over every
call of every episode); episodes that give up (no plan or out of budget) and that end otherwise not
localized (step limit); localized at the wrong state; the mean episode cost over the episodes both
planners localized (paired), with each anytime planner's ratio to today's.

**Extras** (``--extras``): ``plan maps/hallway.yaml --policy`` timed as a process; the contingent
strategy against best-first on the depot (``--contingent-episodes``, paired).

The table goes to ``benchmarks/results/real-floors.md`` (``--output``) and stdout, progress to stderr.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository root: import benchmarks.*

from benchmarks.machine import cpu_name
from benchmarks.planning.settings import ROOT, peak_rss_mib, say, single_threaded
from benchmarks.stats import difference_ci, fmt, mean_or_none, median_or_none

RESULTS = ROOT / "benchmarks" / "results" / "real-floors.md"
MAPS = ("tb3-sandbox", "depot", "depot-corridor")
PLANNERS = ("today", "anytime", "anytime-grow")
DEFAULT_BUDGET = 0.4
DEFAULT_MAX_BUDGET = 0.8
TARGET_MEDIAN_S = 0.5
TARGET_WORST_S = 2.0
TARGET_COST_RATIO = 1.10


def child(
    map_name: str,
    planner: str,
    episodes: int,
    seed: int,
    budget: float,
    max_budget: float | None,
    max_steps: int,
    strategy: str,
) -> None:
    """One map and planner: the episodes' records as JSON on the last line of stdout."""
    from beliefloc import compile_model, load_map, uniform
    from beliefloc.simulation.episode import run_episode, start_state
    from beliefloc.simulation.strategies import PlannerSettings, SharedWork

    base_name, _, variant = map_name.partition("+")
    semantic = load_map(ROOT / "maps" / f"{base_name}.yaml")
    if variant == "region":
        semantic = with_region_models(semantic)
    elif variant:
        raise SystemExit(f"unknown map variant {variant!r} (known: region)")
    model = compile_model(semantic)
    shared = SharedWork.for_model(model)
    if planner == "today":
        settings = PlannerSettings(anytime=False)
    else:
        grow = max_budget if planner == "anytime-grow" else None
        settings = PlannerSettings(anytime=True, time_limit=budget, max_time_limit=grow)
    records = []
    for e in range(episodes):
        started = time.perf_counter()
        record = run_episode(
            model,
            strategy,
            start_state(model, seed, e),
            uniform(model.n_states),
            seed=seed,
            episode=e,
            settings=settings,
            shared=shared,
            max_steps=max_steps,
        )
        records.append(
            {
                "status": record.status.value,
                "correct": record.correct,
                "cost": record.cost,
                "steps": record.steps,
                "plan_seconds": record.plan_seconds,
            }
        )
        say(
            f"  {map_name} {planner} {strategy} episode {e}: {record.status.value}, cost {record.cost:g}, "
            f"{len(record.plan_seconds)} calls, worst {max(record.plan_seconds, default=0.0):.2f} s, "
            f"{time.perf_counter() - started:.1f} s"
        )
    print(json.dumps({"states": model.n_states, "records": records, "peak_mib": peak_rss_mib()}))


REGION_FIELDS = {
    "scan": {"sub_samples": 3, "yaw_samples": 3, "sigma": 0.03, "random": 0.05, "short": 0.1},
    "look": {"sub_samples": 3, "yaw_samples": 3, "fov_edge": 3.0, "range_edge": 0.2},
}
"""The values docs/map-format.md gives "for a real robot" (its region models table)."""


def with_region_models(semantic: Any) -> Any:
    """The map with every look and scan sensor's region fields set to :data:`REGION_FIELDS`: each
    state's readings averaged over its cell and heading sector with continuous noise (issue 26)."""
    sensors = {
        name: sensor.model_copy(update=REGION_FIELDS.get(sensor.type, {})) for name, sensor in semantic.sensors.items()
    }
    return semantic.model_copy(update={"sensors": sensors})


def run_children(jobs: list[tuple[str, list[str]]], parallel: int) -> dict[str, dict[str, Any]]:
    """Run the children ``parallel`` at a time; each one's JSON by label."""
    pending = list(jobs)
    running: list[tuple[str, subprocess.Popen[str], float]] = []
    out: dict[str, dict[str, Any]] = {}
    while pending or running:
        while pending and len(running) < parallel:
            label, command = pending.pop(0)
            say(f"start {label}")
            running.append((label, subprocess.Popen(command, stdout=subprocess.PIPE, text=True, cwd=ROOT), time.time()))
        for item in list(running):
            label, process, started = item
            if process.poll() is None:
                continue
            running.remove(item)
            stdout = process.stdout.read() if process.stdout is not None else ""
            if process.returncode != 0:
                raise SystemExit(f"benchmark child {label} failed (exit {process.returncode})")
            out[label] = json.loads(stdout.strip().splitlines()[-1])
            out[label]["wall_s"] = time.time() - started
            say(f"done {label} in {out[label]['wall_s']:.0f} s")
        time.sleep(0.5)
    return out


def summarise(runs: list[dict[str, Any]]) -> dict[str, Any]:
    calls = [s for r in runs for s in r["plan_seconds"]]
    return {
        "episodes": len(runs),
        "median": median_or_none(calls),
        "worst": max(calls) if calls else None,
        "gave_up": sum(r["status"] in ("no_plan", "budget_exceeded") for r in runs),
        "other": sum(r["status"] not in ("localized", "no_plan", "budget_exceeded") for r in runs),
        "wrong": sum(r["status"] == "localized" and not r["correct"] for r in runs),
    }


def floors_table(results: dict[str, dict[str, Any]], maps: list[str]) -> list[str]:
    lines = [
        "| map | states | planner | episodes | median call s | worst call s | gave up | step limit | wrong "
        "| mean cost (all localized) | cost ratio |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name in maps:
        today = results.get(f"{name}/today")
        if today is None:
            continue
        rows = [("today", today, None)]
        for planner in PLANNERS[1:]:
            data = results.get(f"{name}/{planner}")
            if data is not None:
                rows.append((planner, data, data))
        # paired: the episodes every planner localized
        both = [
            e
            for e in range(len(today["records"]))
            if all(e < len(d["records"]) and d["records"][e]["status"] == "localized" for _, d, _ in rows)
        ]
        base = sum(today["records"][e]["cost"] for e in both)
        for planner, data, _ in rows:
            s = summarise(data["records"])
            costs = [data["records"][e]["cost"] for e in both]
            ratio = sum(costs) / base if base > 0 and planner != "today" else None
            lines.append(
                f"| {name} | {data['states']:,} | {planner} | {s['episodes']} | {fmt(s['median'], 3)} "
                f"| {fmt(s['worst'], 2)} | {s['gave_up']} | {s['other']} | {s['wrong']} "
                f"| {fmt(mean_or_none(costs), 1)} (n={len(both)}) | {fmt(ratio, 3) if ratio is not None else ''} |"
            )
    return lines


def contingent_lines(results: dict[str, dict[str, Any]]) -> list[str]:
    best = results.get("depot/bestfirst-c")
    cont = results.get("depot/contingent")
    if best is None or cont is None:
        return []
    pairs = [
        (c["cost"], b["cost"])
        for c, b in zip(cont["records"], best["records"], strict=False)
        if c["status"] == "localized" and b["status"] == "localized"
    ]
    ci = difference_ci([c - b for c, b in pairs])
    lines = ["", "## Contingent against best-first on the depot (default settings, paired)", ""]
    lines.append("| strategy | episodes | mean plan call s | worst call s | gave up | mean cost (both localized) |")
    lines.append("|---|---:|---:|---:|---:|---:|")
    for name, data, index in (("bestfirst", best, 1), ("contingent", cont, 0)):
        s = summarise(data["records"])
        calls = [x for r in data["records"] for x in r["plan_seconds"]]
        lines.append(
            f"| {name} | {s['episodes']} | {fmt(mean_or_none(calls), 3)} | {fmt(s['worst'], 2)} | {s['gave_up']} "
            f"| {fmt(mean_or_none([p[index] for p in pairs]), 1)} (n={len(pairs)}) |"
        )
    if ci is not None:
        lines.append("")
        lines.append(f"contingent − bestfirst cost: {ci[0]:+.2f}, 95 % interval [{ci[1]:+.2f}, {ci[2]:+.2f}]")
    return lines


def hallway_policy_seconds() -> float:
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "beliefloc", "plan", "maps/hallway.yaml", "--policy", "--json"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        check=False,
    )
    seconds = time.perf_counter() - started
    if done.returncode not in (0, 1):
        raise SystemExit(f"plan --policy failed (exit {done.returncode})")
    return seconds


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--maps", nargs="+", default=list(MAPS))
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--today-episodes", type=int, default=None, help="today's planner (default --episodes)")
    parser.add_argument("--budget", type=float, default=DEFAULT_BUDGET, help="anytime: seconds a plan call")
    parser.add_argument(
        "--max-budget",
        type=float,
        default=DEFAULT_MAX_BUDGET,
        help="anytime: after a call out of budget the next gets twice the seconds, up to this (0: no growth)",
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-steps", type=int, default=200)
    parser.add_argument("--jobs", type=int, default=1, help="children at a time")
    parser.add_argument("--extras", action="store_true", help="hallway --policy time; depot contingent")
    parser.add_argument("--contingent-episodes", type=int, default=10)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--output", type=Path, default=RESULTS)
    parser.add_argument("--child", nargs=4, metavar=("MAP", "PLANNER", "EPISODES", "STRATEGY"))
    args = parser.parse_args(argv)
    single_threaded()
    if args.child:
        name, planner, episodes, strategy = args.child
        max_budget = args.max_budget if args.max_budget > 0 else None
        child(name, planner, int(episodes), args.seed, args.budget, max_budget, args.max_steps, strategy)
        return
    episodes = 3 if args.quick else args.episodes
    today_episodes = 3 if args.quick else (args.today_episodes or episodes)
    base = [sys.executable, str(Path(__file__).resolve()), "--seed", str(args.seed), "--budget", str(args.budget)]
    base += ["--max-budget", str(args.max_budget)]
    base += ["--max-steps", str(args.max_steps)]
    jobs = []
    for name in args.maps:
        jobs.append((f"{name}/today", [*base, "--child", name, "today", str(today_episodes), "bestfirst"]))
        for planner in PLANNERS[1:]:
            jobs.append((f"{name}/{planner}", [*base, "--child", name, planner, str(episodes), "bestfirst"]))
    if args.extras:
        n = 3 if args.quick else args.contingent_episodes
        jobs.append(("depot/contingent", [*base, "--child", "depot", "today", str(n), "contingent"]))
        jobs.append(("depot/bestfirst-c", [*base, "--child", "depot", "today", str(n), "bestfirst"]))
    started = time.perf_counter()
    results = run_children(jobs, args.jobs)
    lines = [
        "# Plans a waiting robot can use on real floors (issue 28)",
        "",
        f"`python benchmarks/bench_real_floors.py {' '.join(argv if argv is not None else sys.argv[1:])}` on "
        f"{cpu_name()}, {time.strftime('%Y-%m-%d')}; anytime budget {args.budget:g} s a plan call "
        f"(anytime-grow: doubling after a call out of budget, up to {args.max_budget:g} s); "
        f"today: {today_episodes} episodes a map, anytime: {episodes}.",
        "",
        *floors_table(results, list(args.maps)),
        "",
        f"Targets (anytime planners): median call ≤ {TARGET_MEDIAN_S} s, worst ≤ {TARGET_WORST_S} s, "
        f"0 episodes that give up, mean cost ≤ {TARGET_COST_RATIO:.2f} × today's where today's completes.",
    ]
    if args.extras:
        seconds = hallway_policy_seconds()
        lines += ["", f"`beliefloc plan maps/hallway.yaml --policy --json`: {seconds:.1f} s (process; target ≤ 3 s)"]
        lines += contingent_lines(results)
    lines += ["", f"Whole run: {time.perf_counter() - started:.0f} s."]
    text = "\n".join(lines) + "\n"
    if not args.quick or args.output != RESULTS:
        args.output.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
