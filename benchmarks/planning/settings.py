"""Settings of the planning benchmark (where the results go, what is compared, the speed targets) and the
set-up of its processes: one BLAS thread, their peak memory, progress on stderr.

Nothing here imports numpy: :func:`single_threaded` must run before its first import.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
"""The repository root: the children run ``python -m benchmarks.planning`` there."""
RESULTS = ROOT / "benchmarks" / "results" / "planning.md"
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
STRATEGY_ORDER = ("bestfirst", "uniform", "random")
HEURISTICS = ("entropy-max-prob", "entropy-prob", "zero")
THRESHOLD = 0.95
KEY_TOLERANCE = 2.0**-31
"""Duplicate tolerance of the baseline: half of beliefloc's key resolution 2^-30."""
EXACT_MAX_STATES = 1_024
"""The baseline's exact-equality (``==``) variant also runs up to this size (10^3 is 16x16x4)."""

# The speed targets (ours; the paper's figures are in paper.py).
TARGET_PLAN_1E4_S = 0.05
TARGET_COST_1E4 = 61.0
TARGET_PLAN_1E5_S = 0.5
TARGET_PEAK_1E5_MIB = 2048.0


def single_threaded() -> None:
    """One BLAS thread, set before numpy is first imported (the children import it)."""
    for name in THREAD_VARIABLES:
        os.environ[name] = "1"


def peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux


def say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def run_json_child(command: list[str], label: str) -> dict[str, Any]:
    """Run a benchmark child process at the repository root, its progress straight to our stderr; its
    result (the JSON on the last line of its stdout) with the wall-clock seconds it took, ``wall_s``."""
    started = time.perf_counter()
    done = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=False, env=os.environ.copy(), cwd=ROOT)
    if done.returncode != 0:
        raise SystemExit(f"benchmark child {label} failed (exit {done.returncode})")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    result["wall_s"] = time.perf_counter() - started
    return result
