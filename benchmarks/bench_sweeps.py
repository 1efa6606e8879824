"""Sweeps on every backend (issue 17): one process, a process pool, a Dask LocalCluster, side by side.

Run by hand from the repository root (not part of the test suite; needs ``pip install -e '.[dask]'``)::

    python benchmarks/bench_sweeps.py              # ~3 min on 2 cores, to benchmarks/results/sweeps.md
    python benchmarks/bench_sweeps.py --repeats 1 --kitchen 300 --output /tmp/sweeps.md   # a smoke run

1. **Tables I-II at 10^4 states**: ``beliefloc generate gridworld --states 10000 --seed 1
   --rotation-failure 0`` (the authors' setting, as ``benchmarks/planning`` with
   ``--rotation-failure 0``), 100 episodes of ``bestfirst`` from uniformly drawn starts, the uniform
   start belief, threshold 0.95 (``benchmarks.planning.settings.THRESHOLD``). The sweep
   (:class:`beliefloc.simulation.episode.EpisodeSweep`) runs on :class:`~beliefloc.simulation.sweep.SerialBackend`
   (``--workers 1``), :class:`~beliefloc.simulation.sweep.PoolBackend` of 2 processes (``--workers 2``; their
   start-up and the model's trip to them counted) and :class:`~beliefloc.simulation.sweep.DaskBackend` on a
   ``LocalCluster(n_workers=2, threads_per_worker=1)`` started beforehand (a user's cluster is
   running already; scattering the model is counted). Speed-up = serial seconds / backend seconds;
   targets: >= 1.7x for the pool, >= 1.5x for Dask. The results of every backend are compared (they
   must be equal) and each worker's peak resident memory is reported.
2. **Dispatch overhead, 1,000 kitchen episodes** (``maps/kitchen.yaml``, bestfirst): a pool of *one*
   worker against this process: the extra seconds -- the worker's start-up, pickling the model and
   the results, the queues -- over the serial seconds. Target < 5 %. For information, a pool of two:
   its efficiency, serial / (2 x pool seconds).
3. **The command end to end** (start-up, loading and compiling the map included):
   ``beliefloc simulate WORLD -n 100 --threshold 0.95 --no-timings --json`` with ``--workers 1`` and
   ``--workers 2``, in subprocesses; the two outputs must be the same bytes.

Each figure is the best of ``--repeats`` (2) runs, one BLAS thread per process.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.planning.settings import THRESHOLD, single_threaded  # noqa: E402

single_threaded()  # before numpy: the spawned workers inherit it

from benchmarks.machine import cpu_name  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results" / "sweeps.md"
TARGET_POOL = 1.7
TARGET_DASK = 1.5
TARGET_OVERHEAD = 0.05


def say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def best_of(repeats: int, run: Callable[[], Any]) -> tuple[float, Any]:
    """The fewest seconds of ``repeats`` calls of ``run``, and the last call's value."""
    best, value = float("inf"), None
    for _ in range(repeats):
        started = time.perf_counter()
        value = run()
        best = min(best, time.perf_counter() - started)
    return best, value


def sweep_results(backend: Any, sweep: Any, count: int) -> list[dict[str, Any]]:
    from beliefloc.simulation.sweep import in_order

    indices = list(range(count))
    return [result for _, result in in_order(backend.run(sweep, indices), indices)]


def mib(value: int) -> str:
    return f"{value / 2**20:.0f} MiB"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--episodes", type=int, default=100, help="episodes of the 10^4-state sweep")
    parser.add_argument("--kitchen", type=int, default=1000, help="kitchen episodes of the overhead measurement")
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()

    from distributed import LocalCluster

    from beliefloc.semantic_map import compile_model, load_map
    from beliefloc.simulation.episode import EpisodeSweep
    from beliefloc.simulation.strategies import PlannerSettings
    from beliefloc.simulation.sweep import DaskBackend, PoolBackend, SerialBackend

    folder = Path(tempfile.mkdtemp(prefix="bench-sweeps-"))
    world = folder / "world.yaml"
    generate = ["generate", "gridworld", "--states", "10000", "--seed", "1", "--rotation-failure", "0"]
    subprocess.run([sys.executable, "-m", "beliefloc", *generate, "-o", str(world)], check=True, capture_output=True)
    model = compile_model(load_map(world))
    sweep = EpisodeSweep(model, ("bestfirst",), seed=0, settings=PlannerSettings(threshold=THRESHOLD), timings=False)
    n = args.episodes

    say(f"1. {n} episodes at {model.n_states:,} states")
    serial_s, serial = best_of(args.repeats, lambda: sweep_results(SerialBackend(), sweep, n))
    say(f"   serial {serial_s:.2f} s")
    pool = PoolBackend(2)
    pool_s, pooled = best_of(args.repeats, lambda: sweep_results(pool, sweep, n))
    say(f"   pool of 2 {pool_s:.2f} s")
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        dask = DaskBackend(cluster.scheduler_address)
        try:
            dask_s, dasked = best_of(args.repeats, lambda: sweep_results(dask, sweep, n))
        finally:
            dask.close()
    say(f"   dask 2 workers {dask_s:.2f} s")
    same = serial == pooled == dasked

    say(f"2. {args.kitchen} kitchen episodes")
    kitchen = compile_model(load_map(ROOT / "maps" / "kitchen.yaml"))
    small = EpisodeSweep(kitchen, ("bestfirst",), seed=0, timings=False)
    k_serial_s, k_serial = best_of(args.repeats, lambda: sweep_results(SerialBackend(), small, args.kitchen))
    one = PoolBackend(1)
    k_one_s, k_one = best_of(args.repeats, lambda: sweep_results(one, small, args.kitchen))
    two = PoolBackend(2)
    k_two_s, k_two = best_of(args.repeats, lambda: sweep_results(two, small, args.kitchen))
    overhead = (k_one_s - k_serial_s) / k_serial_s
    say(f"   serial {k_serial_s:.2f} s, pool of 1 {k_one_s:.2f} s, pool of 2 {k_two_s:.2f} s")
    k_same = k_serial == k_one == k_two

    say("3. the command end to end")
    command = [sys.executable, "-m", "beliefloc", "simulate", str(world), "-n", str(n), "--threshold", str(THRESHOLD)]
    command += ["--no-timings", "--json"]
    outputs: dict[int, bytes] = {}
    cli: dict[int, float] = {}
    for workers in (1, 2):

        def run(workers: int = workers) -> bytes:
            done = subprocess.run([*command, "--workers", str(workers)], capture_output=True, check=True)
            return done.stdout

        cli[workers], outputs[workers] = best_of(args.repeats, run)
        say(f"   --workers {workers}: {cli[workers]:.2f} s")

    def verdict(ok: bool) -> str:
        return "met" if ok else "**missed**"

    rows = [
        ("this process (`--workers 1`)", serial_s, 1.0, "", "—"),
        (
            "process pool of 2 (`--workers 2`)",
            pool_s,
            serial_s / pool_s,
            f"≥ {TARGET_POOL}x: {verdict(serial_s / pool_s >= TARGET_POOL)}",
            ", ".join(mib(v) for v in sorted(pool.peak_rss.values())),
        ),
        (
            "Dask LocalCluster, 2 workers (`--scheduler`)",
            dask_s,
            serial_s / dask_s,
            f"≥ {TARGET_DASK}x: {verdict(serial_s / dask_s >= TARGET_DASK)}",
            ", ".join(mib(v) for v in sorted(dask.peak_rss.values())),
        ),
    ]
    lines = [
        "# Sweeps on every backend",
        "",
        f"`python benchmarks/bench_sweeps.py` on {cpu_name()} ({os.cpu_count()} cores), Python "
        f"{platform.python_version()}, one BLAS thread per process; each figure the best of {args.repeats} runs.",
        "",
        f"## Tables I-II at 10^4 states: {n} episodes of bestfirst",
        "",
        f"`beliefloc generate gridworld --states 10000 --seed 1 --rotation-failure 0` ({model.n_states:,} states), "
        f"uniform starts and start belief, threshold {THRESHOLD}, seed 0. The pool's seconds include starting its "
        "processes and sending them the model; Dask's, scattering the model to a cluster already running.",
        "",
        "| backend | seconds | speed-up | target | peak memory per worker |",
        "| --- | ---: | ---: | --- | --- |",
        *(f"| {name} | {s:.2f} | {x:.2f}x | {t} | {m} |" for name, s, x, t, m in rows),
        "",
        f"Results equal on the three backends: {'yes' if same else '**NO**'}. "
        f"Peak memory of this process (the client, model loaded): {mib(_own_peak())}. Peak memory per worker "
        "is `ru_maxrss` of the last run's workers: a forked pool worker's counts the pages it shares with the "
        "client (copy-on-write); a Dask worker's includes Dask's own.",
        "",
        f"## Dispatch overhead: {args.kitchen} kitchen episodes (bestfirst)",
        "",
        "| run | seconds |",
        "| --- | ---: |",
        f"| this process | {k_serial_s:.2f} |",
        f"| pool of 1 | {k_one_s:.2f} |",
        f"| pool of 2 | {k_two_s:.2f} |",
        "",
        f"Overhead of the pool (one worker against this process): {overhead:+.1%} of the work "
        f"(target < {TARGET_OVERHEAD:.0%}: {verdict(overhead < TARGET_OVERHEAD)}). "
        f"Pool of 2: efficiency {k_serial_s / (2 * k_two_s):.0%} (speed-up {k_serial_s / k_two_s:.2f}x). "
        f"Results equal: {'yes' if k_same else '**NO**'}.",
        "",
        "## The command end to end",
        "",
        f"`beliefloc simulate world.yaml -n {n} --threshold {THRESHOLD} --no-timings --json`, start-up, loading "
        "and compiling the map included:",
        "",
        "| workers | seconds | speed-up |",
        "| --- | ---: | ---: |",
        f"| `--workers 1` | {cli[1]:.2f} | 1.00x |",
        f"| `--workers 2` | {cli[2]:.2f} | {cli[1] / cli[2]:.2f}x |",
        "",
        f"Same bytes: {'yes' if outputs[1] == outputs[2] else '**NO**'}.",
        "",
    ]
    text = "\n".join(lines)
    args.output.write_text(text)
    print(text)


def _own_peak() -> int:
    from beliefloc.simulation.sweep import peak_rss

    return peak_rss()


if __name__ == "__main__":
    main()
