"""Compile time and peak memory of the region models (issue 26's target: the depot's 49,592 states
in <= 5 s and <= 1.5 GiB).

The depot (``maps/depot.yaml``) with every Scan and Look sensor at docs/map-format.md's real-robot
values (``bench_offgrid.REAL_SCAN`` / ``REAL_LOOK``: 3 x 3 positions x 3 yaws per state, sigma 3 cm,
fades of 3 degrees and 0.2 m). Each measurement is a fresh process (``OPENBLAS_NUM_THREADS=1``), so
that its peak resident memory (``ru_maxrss``) is its own: load the map, ``compile_model`` (timed:
the median of ``--repeats`` compiles in that process, the first one included), and the process's
peak RSS. The exact model (the map as shipped) is measured the same way for reference.

``--before REV`` also measures the code of a git revision (``git archive`` into a temporary
directory, run with ``PYTHONPATH`` there), side by side in the same run, and compares its rows with
the current ones (the largest difference of any state's reading probability: the rows are rounded
to ``regions.STEP``, so a few steps at most).

Run by hand from the repository root::

    PYTHONPATH=$PWD python benchmarks/bench_region_compile.py
    PYTHONPATH=$PWD python benchmarks/bench_region_compile.py --before e4ff6b3 --repeats 3
    PYTHONPATH=$PWD python benchmarks/bench_region_compile.py --maps depot kitchen --profile
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

# the repository root, last: import benchmarks.*, but beliefloc from PYTHONPATH (the revision measured)
sys.path.append(str(Path(__file__).resolve().parent.parent))

from benchmarks.planning.settings import ROOT, peak_rss_mib, single_threaded

TARGET_S = 5.0
TARGET_MIB = 1536.0


def child(map_name: str, region: bool, repeats: int, rows_out: str | None, profile: bool) -> dict[str, Any]:
    """Load and compile ``map_name`` (region model or the exact one) ``repeats`` times in this process."""
    import numpy as np

    from beliefloc import compile_model, load_map

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_offgrid import with_region_model

    smap = load_map(ROOT / "maps" / f"{map_name}.yaml")
    if region:
        smap = with_region_model(smap)
    import beliefloc

    seconds, cpu = [], []
    model = None
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        if profile and not seconds:
            import cProfile
            import pstats

            profiler = cProfile.Profile()
            model = profiler.runcall(compile_model, smap)
            pstats.Stats(profiler, stream=sys.stderr).sort_stats("tottime").print_stats(12)
        else:
            model = compile_model(smap)
        seconds.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    assert model is not None
    if rows_out is not None:  # every perception part's row of every state, to compare two revisions
        rows = {
            part.name: part.confusion[part.truth]
            for action in model.actions
            if action.transition is None
            for part in action.observation.parts
        }
        np.savez_compressed(rows_out, **rows)
    return {
        "states": model.n_states,
        "first_s": seconds[0],
        "median_s": float(np.median(seconds)),
        "median_cpu_s": float(np.median(cpu)),
        "all_s": seconds,
        "code": str(Path(beliefloc.__file__).resolve().parent.parent),
        "peak_mib": peak_rss_mib(),
        "distinct_rows": {
            part.name: int(part.confusion.shape[0])
            for action in model.actions
            if action.transition is None
            for part in action.observation.parts
        },
    }


def run_child(
    code: Path, map_name: str, region: bool, repeats: int, rows_out: Path | None, profile: bool
) -> dict[str, Any]:
    command = [sys.executable, str(Path(__file__).resolve()), "--child", map_name, "--repeats", str(repeats)]
    if region:
        command.append("--region")
    if rows_out is not None:
        command += ["--rows-out", str(rows_out)]
    if profile:
        command.append("--profile")
    env = os.environ.copy()
    env["PYTHONPATH"] = str(code)
    done = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=False, env=env, cwd=ROOT)
    if done.returncode != 0:
        raise SystemExit(f"benchmark child {map_name} ({code}) failed (exit {done.returncode})")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    if Path(result["code"]) != code.resolve():  # the child must run the revision asked for
        raise SystemExit(f"benchmark child ran the beliefloc of {result['code']}, not of {code}")
    return result


def export_revision(rev: str, into: Path) -> Path:
    """The code of commit ``rev`` unpacked under ``into`` (kept if already there), with its compiled parts built
    as an install builds them: without them that code's search runs its Python or NumPy loops, not the code a
    user of that commit ran (a side-by-side run once compared today's C with a baseline's Python)."""
    if not (into / "beliefloc").exists():
        into.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "archive", rev], cwd=ROOT, stdout=subprocess.PIPE, check=True)
        subprocess.run(["tar", "-x", "-C", str(into)], input=archive.stdout, check=True)
    if (into / "setup.py").exists() and not list((into / "beliefloc").rglob("*.so")):
        print(f"building the compiled parts of {into} ...", file=sys.stderr, flush=True)
        subprocess.run(
            [sys.executable, "setup.py", "-q", "build_ext", "--inplace"],
            cwd=into, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
    return into


def write_bytecode(code: Path) -> None:
    """Byte code for every module of ``code``'s package, as an install writes it: otherwise a process compiles
    every module changed since its last .pyc (PYTHONDONTWRITEBYTECODE, as on CI, never writes them), and a
    baseline's every module, 0.1-0.2 s that are not the code's."""
    subprocess.run(
        [sys.executable, "-m", "compileall", "-q", "beliefloc"], cwd=code, check=True, stdout=subprocess.DEVNULL
    )


def largest_difference(a: Path, b: Path) -> float:
    import numpy as np

    with np.load(a) as x, np.load(b) as y:
        assert set(x.files) == set(y.files), (x.files, y.files)
        return max(float(np.abs(x[k] - y[k]).max()) for k in x.files)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--maps", nargs="+", default=["depot"])
    parser.add_argument("--repeats", type=int, default=3, help="compiles per process (the median is reported)")
    parser.add_argument("--before", help="a git revision to measure beside the current code")
    parser.add_argument("--profile", action="store_true", help="cProfile the first region compile (to stderr)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--region", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--rows-out", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    single_threaded()
    if args.child is not None:
        print(json.dumps(child(args.child, args.region, args.repeats, args.rows_out, args.profile)))
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        codes = {"current": ROOT}
        if args.before is not None:
            codes[f"before ({args.before})"] = export_revision(args.before, Path(tmp) / "before")
        print(
            "| map | code | model | states | compile s (first) | compile s (median) | CPU s (median) "
            "| peak RSS MiB | distinct rows |"
        )
        print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for map_name in args.maps:
            rows_files = {}
            for label, code in codes.items():
                for region in (False, True):
                    rows_out = Path(tmp) / f"{map_name}-{len(rows_files)}.npz" if region else None
                    r = run_child(code, map_name, region, args.repeats, rows_out, args.profile and region)
                    if rows_out is not None:
                        rows_files[label] = rows_out
                    distinct = sum(r["distinct_rows"].values())
                    print(
                        f"| {map_name} | {label} | {'region' if region else 'exact'} | {r['states']} | "
                        f"{r['first_s']:.2f} | {r['median_s']:.2f} | {r['median_cpu_s']:.2f} | "
                        f"{r['peak_mib']:.0f} | {distinct} |",
                        flush=True,
                    )
            if len(rows_files) == 2:
                a, b = rows_files.values()
                most = largest_difference(a, b)
                print(f"\n{map_name}: largest difference of a region row, before vs current: {most:.4f}")
    print(f"\ntargets (the depot's region model): compile <= {TARGET_S:g} s, peak RSS <= {TARGET_MIB:.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
