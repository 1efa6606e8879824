"""``track MAP --steps FILE`` over a million-step log: before and after, side by side in one run.

    python benchmarks/bench_track_steps.py                  # 10^6 steps, 3 repeats (~8 min), to results/track-steps.md
    python benchmarks/bench_track_steps.py --steps 100000 --repeats 1 --output /tmp/t.md   # a smoke run
    python benchmarks/bench_track_steps.py --before e4ff6b3 --after HEAD  # two commits

The log is what a robot in the kitchen (``maps/kitchen.yaml``, 36 states) would write: a seeded
walk whose true state moves by the map's own transitions (a move fails with the map's 0.02) and
whose observations are drawn from the map's own sensor model (``look``'s false positives and
negatives, ``scan``'s bin errors), so every step is valid and every observation possible; moves
are written ``forward`` or ``forward=none`` as logs write them, and a comment or blank line comes
now and then.

Each of ``track -q``, ``track --json`` and the default output (more than 1,000 steps: as ``-q``,
with a note on stderr) runs in a fresh process (``OPENBLAS_NUM_THREADS=1``, stdout a pipe that this
process hashes) for the code of ``--before`` (a commit, extracted with ``git archive``) and for the
working tree, alternately, ``--repeats`` times; the table gives the least wall time of the repeats,
the child's CPU seconds and peak RSS, the output's size and whether the two outputs' SHA-256 agree.
Target (issue 30): each under 30 s and 2 GB on this 2-core machine shared with other work, so the
load average is printed beside the figures.
"""

from __future__ import annotations

import argparse
import bisect
import hashlib
import os
import resource
import subprocess
import sys
import tarfile
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.machine import cpu_name  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
KITCHEN = ROOT / "maps" / "kitchen.yaml"
MODES = {"-q": ["-q"], "--json": ["--json"], "default": []}
WEIGHTS = {"forward": 0.25, "backward": 0.05, "rotate_cw": 0.1, "rotate_ccw": 0.1, "look": 0.25, "scan": 0.25}
"""How often the walk takes each of the kitchen's actions."""


def write_log(path: Path, n_steps: int, seed: int) -> None:
    """A log of ``n_steps`` valid steps of a simulated robot in the kitchen (see the module docstring)."""
    from beliefloc.cli.common import open_model

    model = open_model(KITCHEN)
    rng = np.random.default_rng(seed)
    names = list(WEIGHTS)
    actions = [model.action(name) for name in names]
    n = model.n_states
    every = np.arange(n)
    # per action, per true state: the cumulative distribution of the next state / of the observation
    moves: list[list[list[float]] | None] = []
    sights: list[list[list[float]]] = []
    for action in actions:
        t = action.transition
        moves.append(None if t is None else np.cumsum(t.toarray(), axis=1).tolist())
        sights.append(np.cumsum(action.observation.likelihood_matrix(every), axis=1).tolist())
    observation_names = [action.observation.names() for action in actions]
    chosen = rng.choice(len(names), size=n_steps, p=list(WEIGHTS.values())).tolist()
    draws = rng.random((n_steps, 3)).tolist()
    state = int(rng.integers(n))
    lines = [f"# kitchen walk, seed {seed}, {n_steps:,} steps (benchmarks/bench_track_steps.py)"]
    for k, (u_move, u_sight, u_form) in zip(chosen, draws, strict=True):
        move = moves[k]
        if move is not None:
            state = min(bisect.bisect_right(move[state], u_move * move[state][-1]), n - 1)
        row = sights[k][state]
        o = min(bisect.bisect_right(row, u_sight * row[-1]), len(row) - 1)
        bare = move is not None and u_form < 0.5  # a move written without its reading (none) half the time
        lines.append(names[k] if bare else f"{names[k]}={observation_names[k][o]}")
        if u_form > 0.9995:
            lines.append("" if u_form > 0.99975 else "# the robot paused here")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


@dataclass
class Run:
    seconds: float
    cpu: float
    rss_mib: float
    size: int
    sha256: str
    code: int
    stderr: str


def run_track(code_root: Path, log: Path, options: list[str]) -> Run:
    """``python -m beliefloc track kitchen --steps LOG OPTIONS`` on the code under ``code_root``."""
    env = {**os.environ, "PYTHONPATH": str(code_root), "OPENBLAS_NUM_THREADS": "1", "COLUMNS": "100"}
    env.pop("FORCE_COLOR", None)
    command = [sys.executable, "-m", "beliefloc", "track", str(KITCHEN), "--steps", str(log), *options]
    digest = hashlib.sha256()
    size = 0
    with tempfile.TemporaryFile() as errors:
        start = time.perf_counter()
        child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=errors, env=env, cwd=code_root)
        assert child.stdout is not None
        while chunk := child.stdout.read(1 << 20):
            digest.update(chunk)
            size += len(chunk)
        _, status, usage = os.wait4(child.pid, 0)
        seconds = time.perf_counter() - start
        child.returncode = os.waitstatus_to_exitcode(status)
        child.stdout.close()
        errors.seek(0)
        stderr = errors.read().decode("utf-8", "replace")
    return Run(
        seconds,
        usage.ru_utime + usage.ru_stime,
        usage.ru_maxrss / 1024,
        size,
        digest.hexdigest(),
        child.returncode,
        stderr,
    )


def extract(commit: str, into: Path) -> Path:
    """The package and the maps of ``commit``, as ``git archive`` gives them, in a new folder of ``into``."""
    folder = Path(tempfile.mkdtemp(dir=into))
    archive = folder / "code.tar"
    with archive.open("wb") as out:
        subprocess.run(["git", "archive", commit, "beliefloc", "maps"], cwd=ROOT, stdout=out, check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(folder, filter="data")
    return folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=1_000_000, help="steps in the log (10^6)")
    parser.add_argument("--seed", type=int, default=30)
    parser.add_argument("--repeats", type=int, default=3, help="runs of each (code, mode); the least time counts")
    parser.add_argument("--before", default="e4ff6b3", help="the commit to compare with (before issue 30's speed-up)")
    parser.add_argument("--after", help="a commit to time instead of the working tree")
    parser.add_argument("--modes", nargs="+", choices=list(MODES), default=list(MODES))
    parser.add_argument("--output", type=Path, default=RESULTS / "track-steps.md")
    parser.add_argument("--write-log", type=Path, help=argparse.SUPPRESS)  # the child that writes the log
    args = parser.parse_args()
    if args.write_log is not None:
        write_log(args.write_log, args.steps, args.seed)
        return

    with tempfile.TemporaryDirectory(prefix="bench-track-") as scratch:
        folder = Path(scratch)
        log = folder / "kitchen-walk.log"
        start = time.perf_counter()
        # in a child: a child's peak RSS counts the pages it shares with this process until its exec,
        # and the log's million lines would stay in this one's heap
        command = [
            sys.executable,
            __file__,
            "--write-log",
            str(log),
            "--steps",
            str(args.steps),
            "--seed",
            str(args.seed),
        ]
        subprocess.run(command, check=True)
        print(f"log: {log.stat().st_size / 2**20:.1f} MiB in {time.perf_counter() - start:.1f} s", flush=True)
        codes = {
            "before": extract(args.before, folder),
            "after": ROOT if args.after is None else extract(args.after, folder),
        }
        loads: list[float] = []
        best: dict[tuple[str, str], Run] = {}
        hashes: dict[tuple[str, str], set[str]] = {}
        for mode in args.modes:
            for repeat in range(args.repeats):
                for code, code_root in codes.items():
                    loads.append(os.getloadavg()[0])
                    run = run_track(code_root, log, MODES[mode])
                    print(
                        f"{mode:8} {code:6} #{repeat + 1}: {run.seconds:6.2f} s wall, {run.cpu:6.2f} s cpu, "
                        f"{run.rss_mib:5.0f} MiB, {run.size:,} bytes, exit {run.code}, load {loads[-1]:.2f}",
                        flush=True,
                    )
                    if run.code != 0:
                        print(run.stderr, file=sys.stderr)
                    hashes.setdefault((code, mode), set()).add(run.sha256)
                    if (code, mode) not in best or run.seconds < best[code, mode].seconds:
                        best[code, mode] = run

    own_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    after = "the working tree" if args.after is None else f"commit `{args.after}`"
    lines = [
        f"# track --steps: a {args.steps:,}-step log, before and after",
        "",
        f"{args.steps:,} steps of a seeded walk in the kitchen (seed {args.seed}; "
        "`python benchmarks/bench_track_steps.py`), each mode in a fresh process, stdout a pipe hashed by "
        f"the benchmark; least wall time of {args.repeats} repeats. Before: commit `{args.before}`; after: "
        f"{after}. CPU: {cpu_name()}, {os.cpu_count()} cores shared with other work; load average "
        f"(1 min) before each run: {min(loads):.2f} to {max(loads):.2f}. Peak RSS is the child's (it counts "
        f"what it shared with the benchmark before its exec: {own_rss:.0f} MiB at most).",
        "",
        "| mode | before s | after s | before / after | before CPU s | after CPU s | peak RSS MiB before / after "
        "| output bytes | same output |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for mode in args.modes:
        old, new = best["before", mode], best["after", mode]
        same = hashes["before", mode] == hashes["after", mode] and len(hashes["after", mode]) == 1
        lines.append(
            f"| {mode} | {old.seconds:.2f} | {new.seconds:.2f} | {old.seconds / new.seconds:.2f} | {old.cpu:.2f} | "
            f"{new.cpu:.2f} | {old.rss_mib:.0f} / {new.rss_mib:.0f} | {new.size:,} | {'yes' if same else 'NO'} |"
        )
    lines += ["", "Target (issue 30): each mode under 30 s and 2 GB."]
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
