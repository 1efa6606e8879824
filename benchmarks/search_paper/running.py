"""Running a part's trials, in parallel when there are workers: a trial depends only on the seed and its
index, so chunks of trials can run anywhere and be joined in index order."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from beliefloc.knowledge import load_domain
from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.experiment import Arm, ArmOutcome, TrialRecord, TrialSettings, run_trials

from .settings import DOMAIN, Part


def say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


_DOMAINS: dict[str, Domain] = {}


def _chunk(
    path: str, arms: tuple[Arm, ...], settings: TrialSettings, seed: int, first: int, count: int, scenes: bool
) -> Any:
    domain = _DOMAINS.get(path)
    if domain is None:
        domain = _DOMAINS[path] = load_domain(path)
    return run_trials(domain, arms, trials=count, seed=seed, settings=settings, first=first, scenes=scenes)


def run_part(part: Part, seed: int, jobs: int, pool: ProcessPoolExecutor | None) -> tuple[list[TrialRecord], float]:
    """All trials of a part, in index order, and the wall-clock seconds they took."""
    started = time.perf_counter()
    size = max(1, min(50, math.ceil(part.trials / (4 * jobs))))
    starts = list(range(0, part.trials, size))
    done: dict[int, list[TrialRecord]] = {}
    if pool is None:
        for first in starts:
            done[first] = _chunk(
                str(DOMAIN), part.arms, part.settings, seed, first, min(size, part.trials - first), part.scenes
            )
            _progress(part, sum(len(v) for v in done.values()), started)
    else:
        futures = {
            pool.submit(
                _chunk,
                str(DOMAIN),
                part.arms,
                part.settings,
                seed,
                first,
                min(size, part.trials - first),
                part.scenes,
            ): first
            for first in starts
        }
        for future in as_completed(futures):
            done[futures[future]] = future.result()
            _progress(part, sum(len(v) for v in done.values()), started)
    records = [record for first in starts for record in done[first]]
    seconds = time.perf_counter() - started
    say(f"  {part.label}: {part.trials} trials x {len(part.arms)} arms in {seconds:.1f} s")
    return records, seconds


def _progress(part: Part, count: int, started: float) -> None:
    """A line that rewrites itself on a terminal (nothing when stderr is a file)."""
    if sys.stderr.isatty():
        line = f"  {part.label}: {count}/{part.trials} ({time.perf_counter() - started:.0f} s)"
        print("\r" + line, end="", file=sys.stderr, flush=True)
        if count == part.trials:
            print("\r" + " " * len(line) + "\r", end="", file=sys.stderr, flush=True)


def outcomes(records: Sequence[TrialRecord], arm: Arm) -> list[ArmOutcome]:
    """``arm``'s outcome in every record, in trial order."""
    return [next(o for o in r.outcomes if o.arm == arm.name) for r in records]
