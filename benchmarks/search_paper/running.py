"""Running a part's trials, in parallel when there are workers: a trial depends only on the seed and its
index, so chunks of trials can run anywhere and be joined in index order."""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence

from beliefloc.knowledge import load_domain
from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.experiment import Arm, ArmOutcome, TrialRecord, TrialSweep
from beliefloc.simulation.sweep import Backend, in_order

from .settings import DOMAIN, Part


def say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


_DOMAINS: dict[str, Domain] = {}


def run_part(part: Part, seed: int, backend: Backend) -> tuple[list[TrialRecord], float]:
    """All trials of a part, in index order, and the wall-clock seconds they took: the trials run as
    ``search simulate``'s do, a :class:`~beliefloc.object_search.experiment.TrialSweep` on one of
    beliefloc's sweep backends (this process, a process pool)."""
    started = time.perf_counter()
    domain = _DOMAINS.get(str(DOMAIN))
    if domain is None:
        domain = _DOMAINS[str(DOMAIN)] = load_domain(DOMAIN)
    sweep = TrialSweep(domain, part.arms, seed, part.settings, scenes=part.scenes)
    indices = range(part.trials)
    space = search_space(domain)
    records: list[TrialRecord] = []
    for count, (_, result) in enumerate(in_order(backend.run(sweep, indices), indices), start=1):
        records.append(TrialRecord.from_json(result, space))
        _progress(part, count, started)
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
