"""LAO* before and after issue 28's work: ``plan --policy`` on a map, side by side in one run.

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_lao.py                       # maps/hallway.yaml, the three searches below
    python benchmarks/bench_lao.py --map depot --max-expansions 32 --repeats 3
    python benchmarks/bench_lao.py --cli --repeats 3     # the whole command, before and after
    python benchmarks/bench_lao.py --simulate 20 --map tb3-sandbox   # simulate -s contingent, before and after
    python benchmarks/bench_lao.py --append              # also append the table to results/contingent.md

The searches, each from the uniform belief with the command line's defaults (threshold 0.95, the entropy
estimate, ``--prune-below`` 0.001, 200,000 expansions) but a time limit of ``--time-limit`` (600 s) so
that a slow one still finishes, in this order, one process, ``OPENBLAS_NUM_THREADS=1``:

1. **before**: ``beliefloc/planning/contingent.py`` as it was at ``--before`` (git revision, default the
   commit the latest of issue 28's LAO* work started from), loaded from git into a module of its own (every
   other module is today's);
2. **traversal**: today's module with the reference search it keeps (``_TraversalPlanner``: a traversal of
   the whole best policy per expansion), so that the bookkeeping alone differs from (3);
3. **incremental**: today's ``PolicyPlanner``.

Per search: the status, expansions, the expected cost of the policy, its nodes, CPU seconds
(``time.process_time``) and wall seconds, and milliseconds per expansion. The machine is shared: the
ratios between the rows of one run are what to read.

With ``--cli`` the whole command ``python -m beliefloc plan maps/MAP.yaml --policy --json`` is timed instead
(what issue 28's "<= 3 s" is about: process start, map compilation and the search), in turn with the package
as it was at ``--before`` (``git archive`` into a temporary directory with its compiled parts built, on
``PYTHONPATH``; ``python -P`` keeps the working directory's package out) and with today's, both with their
byte code written, ``--repeats`` times: wall seconds and the child's
CPU seconds (user + system), and from its JSON the status, expansions, expected cost and policy nodes.

With ``--simulate N`` the command is ``python -m beliefloc simulate maps/MAP.yaml -n N -s contingent --seed
SEED --json`` (the same episodes for both codes): per code its summary (localized, correct, mean cost, mean
plan seconds a call, replans) and the child's CPU seconds.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository root: import benchmarks.*
from benchmarks.bench_region_compile import export_revision, write_bytecode
from benchmarks.machine import cpu_name
from benchmarks.planning.settings import ROOT, say, single_threaded

RESULTS = ROOT / "benchmarks" / "results" / "contingent.md"
BEFORE = "6127da6"
"""The revision the latest of issue 28's LAO* work started from (e4ff6b3: the incremental bookkeeping's)."""


def load_before(revision: str) -> Any:
    """``beliefloc.planning.contingent`` as it was at ``revision``, as a module of its own."""
    source = subprocess.run(
        ["git", "show", f"{revision}:beliefloc/planning/contingent.py"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    module = types.ModuleType("contingent_before")
    module.__file__ = f"{revision}:beliefloc/planning/contingent.py"
    sys.modules[module.__name__] = module  # dataclasses look their module up
    exec(compile(source, module.__file__, "exec"), module.__dict__)
    return module


def run(name: str, planner: Any, belief: Any, args: argparse.Namespace) -> dict[str, Any]:
    cpu, wall = time.process_time(), time.perf_counter()
    result = planner.plan(belief, max_expansions=args.max_expansions, time_limit=args.time_limit)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    row = {
        "name": name,
        "status": result.status.value,
        "expanded": result.expanded,
        "cost": result.expected_cost,
        "nodes": result.nodes(),
        "cpu": cpu,
        "wall": wall,
    }
    say(f"  {name}: {row}")
    return row


def report(args: argparse.Namespace, rows: list[dict[str, Any]], load: tuple[float, float]) -> str:
    first = {row["name"]: row for row in rows if row["repeat"] == 0}
    lines = [
        f"## LAO* bookkeeping, before and after ({datetime.date.today().isoformat()})",
        "",
        f"`python benchmarks/bench_lao.py {' '.join(args.argv)}`: `plan maps/{args.map}.yaml --policy` from the "
        f"uniform belief, at most {args.max_expansions:,} expansions, time limit {args.time_limit:g} s. "
        f"Machine: {cpu_name()}, {os.cpu_count()} cores, shared; OPENBLAS_NUM_THREADS=1; 1-minute load average "
        f"{load[0]:.2f} at the start, {load[1]:.2f} at the end. before: `contingent.py` at `{args.before}`; "
        "traversal: today's module with its reference search (a traversal of the best policy per expansion); "
        "incremental: today's `PolicyPlanner`.",
        "",
        "| search | run | status | expansions | expected cost | policy nodes | CPU s | wall s | ms / expansion "
        "| CPU vs before |",
        "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in rows:
        base = first.get("before")
        ratio = f"{base['cpu'] / row['cpu']:.1f}x" if base and row["cpu"] > 0 else "-"
        lines.append(
            f"| {row['name']} | {row['repeat'] + 1} | {row['status']} | {row['expanded']:,} | {row['cost']:.4f} | "
            f"{row['nodes']:,} | {row['cpu']:.2f} | {row['wall']:.2f} | "
            f"{1e3 * row['cpu'] / max(1, row['expanded']):.3f} | {ratio} |"
        )
    return "\n".join(lines) + "\n"


def policy_nodes(policy: dict[str, Any]) -> int:
    """Distinct nodes of ``plan --policy --json``'s nested policy (a node met again is ``same_as``)."""
    seen: set[int] = set()
    stack = [policy]
    while stack:
        node = stack.pop()
        seen.add(node["id"])
        stack.extend(branch["node"] for branch in node.get("branches", ()))
    return len(seen)


def check_code(code: Path) -> None:
    """The package a child with ``code`` on PYTHONPATH imports must be ``code``'s: ``-P`` keeps the working
    directory (the repository root, where the maps are) off ``sys.path``."""
    probe = [sys.executable, "-P", "-c", "import beliefloc; print(beliefloc.__file__)"]
    env = {**os.environ, "PYTHONPATH": str(code)}
    found = subprocess.run(probe, stdout=subprocess.PIPE, text=True, check=True, env=env, cwd=ROOT).stdout.strip()
    if not Path(found).resolve().is_relative_to(code.resolve()):
        raise SystemExit(f"a child with PYTHONPATH={code} imports {found}")


def run_cli(name: str, code: Path, args: argparse.Namespace) -> dict[str, Any]:
    """``plan --policy --json`` as a child process with ``code`` on PYTHONPATH (at the repository root, where
    the maps are)."""
    command = [sys.executable, "-P", "-m", "beliefloc", "plan", f"maps/{args.map}.yaml", "--policy", "--json"]
    command += ["--max-expansions", str(args.max_expansions), "--time-limit", str(args.time_limit)]
    env = {**os.environ, "PYTHONPATH": str(code)}
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    done = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=False, env=env, cwd=ROOT)
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 1):
        raise SystemExit(f"{name}: {' '.join(command)} failed (exit {done.returncode})")
    result = json.loads(done.stdout)
    row = {
        "name": name,
        "status": result["status"],
        "expanded": result["expanded"],
        "cost": result["expected_cost"],
        "nodes": policy_nodes(result["policy"]),
        "cpu": (after.ru_utime - usage.ru_utime) + (after.ru_stime - usage.ru_stime),
        "wall": wall,
        "search": result["seconds"],
    }
    say(f"  {name}: {row}")
    return row


def report_cli(args: argparse.Namespace, rows: list[dict[str, Any]], load: tuple[float, float]) -> str:
    first = {row["name"]: row for row in rows if row["repeat"] == 0}
    lines = [
        f"## `plan maps/{args.map}.yaml --policy`, the whole command, before and after ({datetime.date.today()})",
        "",
        f"`python benchmarks/bench_lao.py {' '.join(args.argv)}`: `python -m beliefloc plan maps/{args.map}.yaml "
        f"--policy --json --max-expansions {args.max_expansions} --time-limit {args.time_limit:g}`, in turn with "
        f"the package at `{args.before}` (`git archive`) and today's. Machine: {cpu_name()}, {os.cpu_count()} cores, "
        f"shared; OPENBLAS_NUM_THREADS=1; 1-minute load average {load[0]:.2f} at the start, {load[1]:.2f} at the "
        "end. CPU: the child's user + system seconds; search: the seconds the planner reports (wall).",
        "",
        "| code | run | status | expansions | expected cost | policy nodes | search s | CPU s | wall s "
        "| CPU vs before |",
        "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in rows:
        base = first.get("before")
        ratio = f"{base['cpu'] / row['cpu']:.1f}x" if base and row["cpu"] > 0 else "-"
        lines.append(
            f"| {row['name']} | {row['repeat'] + 1} | {row['status']} | {row['expanded']:,} | {row['cost']:.6f} | "
            f"{row['nodes']:,} | {row['search']:.2f} | {row['cpu']:.2f} | {row['wall']:.2f} | {ratio} |"
        )
    return "\n".join(lines) + "\n"


def run_simulate(name: str, code: Path, args: argparse.Namespace) -> dict[str, Any]:
    """``simulate -s contingent --json`` as a child process with ``code`` on PYTHONPATH."""
    command = [sys.executable, "-P", "-m", "beliefloc", "simulate", f"maps/{args.map}.yaml", "-n", str(args.simulate)]
    command += ["-s", "contingent", "--seed", str(args.seed), "--json"]
    env = {**os.environ, "PYTHONPATH": str(code)}
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    done = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=False, env=env, cwd=ROOT)
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 1):
        raise SystemExit(f"{name}: {' '.join(command)} failed (exit {done.returncode})")
    summary = json.loads(done.stdout)["summary"]["contingent"]
    row = {
        "name": name,
        **summary,
        "cpu": (after.ru_utime - usage.ru_utime) + (after.ru_stime - usage.ru_stime),
        "wall": wall,
    }
    say(f"  {name}: {row}")
    return row


def report_simulate(args: argparse.Namespace, rows: list[dict[str, Any]], load: tuple[float, float]) -> str:
    lines = [
        f"## `simulate maps/{args.map}.yaml -s contingent`, before and after ({datetime.date.today()})",
        "",
        f"`python benchmarks/bench_lao.py {' '.join(args.argv)}`: `python -m beliefloc simulate maps/{args.map}.yaml "
        f"-n {args.simulate} -s contingent --seed {args.seed} --json` (the library's defaults), in turn with the "
        f"package at `{args.before}` (`git archive`) and today's: the same episodes. Machine: {cpu_name()}, "
        f"{os.cpu_count()} cores, shared; OPENBLAS_NUM_THREADS=1; 1-minute load average {load[0]:.2f} at the "
        f"start, {load[1]:.2f} at the end. Plan s: mean wall seconds of a plan call; CPU: the child's user + "
        "system seconds for the whole run.",
        "",
        "| code | run | episodes | localized | correct | mean cost | plan s | replans | steps | CPU s | wall s |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in rows:
        lines.append(
            f"| {row['name']} | {row['repeat'] + 1} | {row['episodes']} | {row['localized']} | {row['correct']} | "
            f"{row['mean_cost']:.2f} | {row['mean_plan_seconds']:.3f} | {row['mean_replans']:.2f} | "
            f"{row['mean_steps']:.1f} | {row['cpu']:.1f} | {row['wall']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def main_cli(args: argparse.Namespace) -> str:
    load_start = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        codes = {"before": export_revision(args.before, Path(tmp) / "before"), "after": ROOT}
        for code in codes.values():
            check_code(code)
            write_bytecode(code)
        for repeat in range(args.repeats):
            for name, code in codes.items():
                if name not in args.skip:
                    run = run_simulate if args.simulate else run_cli
                    rows.append({**run(name, code, args), "repeat": repeat})
    report = report_simulate if args.simulate else report_cli
    return report(args, rows, (load_start, os.getloadavg()[0]))


def main(argv: list[str] | None = None) -> int:
    single_threaded()
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--map", default="hallway", help="a map in maps/ (name without .yaml)")
    parser.add_argument("--max-expansions", type=int, default=200_000)
    parser.add_argument("--time-limit", type=float, default=600.0)
    parser.add_argument("--before", default=BEFORE, help="git revision of the 'before' contingent.py")
    parser.add_argument("--repeats", type=int, default=1, help="runs of each search (in turn)")
    parser.add_argument("--skip", nargs="*", default=[], help="searches not to run (before, traversal, ...)")
    parser.add_argument("--append", action="store_true", help=f"append the table to {RESULTS.name}")
    parser.add_argument("--cli", action="store_true", help="time the whole plan command, before and after")
    parser.add_argument("--simulate", type=int, default=0, help="episodes of simulate -s contingent, before and after")
    parser.add_argument("--seed", type=int, default=0, help="--simulate: the episodes' seed")
    args = parser.parse_args(argv)
    args.argv = sys.argv[1:] if argv is None else argv
    if args.cli or args.simulate:
        text = main_cli(args)
        print(text)
        if args.append:
            with RESULTS.open("a") as out:
                out.write("\n" + text)
        return 0

    from beliefloc.belief import uniform
    from beliefloc.planning import contingent
    from beliefloc.semantic_map import compile_model, load_map

    model = compile_model(load_map(ROOT / "maps" / f"{args.map}.yaml"))
    before = load_before(args.before)
    searches = {
        "before": lambda: before.PolicyPlanner(model),
        "traversal": lambda: contingent._TraversalPlanner(model),
        "incremental": lambda: contingent.PolicyPlanner(model),
    }
    load_start = os.getloadavg()[0]
    rows = []
    for repeat in range(args.repeats):
        for name, make in searches.items():
            if name in args.skip:
                continue
            row = run(name, make(), uniform(model.n_states), args)
            rows.append({**row, "repeat": repeat})
    text = report(args, rows, (load_start, os.getloadavg()[0]))
    print(text)
    if args.append:
        with RESULTS.open("a") as out:
            out.write("\n" + text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
