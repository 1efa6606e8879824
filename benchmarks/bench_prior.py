"""Knowledge-base prior performance on ``domains/home.yaml`` (Zhang et al. 2015, Sec. III-C1).

Run by hand from the repository root (not part of the test suite)::

    python benchmarks/bench_prior.py               # 50 repeats
    python benchmarks/bench_prior.py --repeats 200

Measured after start-up (Python, clingo and beliefloc imported; one warm-up run):

* **end to end**: read and validate the YAML, ground and solve with clingo, compute Eq. 2-5;
  clingo's grounding and solving times are reported apart (``KnowledgeBase.timings``).
* **revision, one new fact**: a known object seen in another room -- multi-shot: set its external
  ``observed(O, R, I)`` true and solve again -- against grounding the whole program afresh with the
  fact (what revision would cost without multi-shot solving); and a new object, which needs a
  new grounding either way.

Targets on this 2-core machine: prior end to end < 50 ms, revision with one new fact < 10 ms.
The table is printed and written to ``benchmarks/results/prior.md``.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import clingo

from beliefloc.knowledge import KnowledgeBase, Observation, load_domain

ROOT = Path(__file__).resolve().parent.parent
DOMAIN = ROOT / "domains" / "home.yaml"
RESULTS = ROOT / "benchmarks" / "results" / "prior.md"
TARGET_PRIOR_MS = 50.0
TARGET_REVISION_MS = 10.0


def _median_ms(run: Callable[[], object], repeats: int) -> float:
    run()  # warm-up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1000


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=50)
    args = parser.parse_args(argv)
    repeats: int = args.repeats

    def end_to_end() -> KnowledgeBase:
        kb = KnowledgeBase(load_domain(DOMAIN))
        kb.prior("printer")
        return kb

    kb = end_to_end()
    ground_ms = kb.timings.ground * 1000
    solve_ms = kb.timings.solve * 1000
    prior_ms = _median_ms(end_to_end, repeats)
    domain = load_domain(DOMAIN)
    load_ms = _median_ms(lambda: load_domain(DOMAIN), repeats)
    grounds, solves = [], []
    for _ in range(repeats):
        fresh = KnowledgeBase(domain)
        fresh.prior("printer")
        grounds.append(fresh.timings.ground * 1000)
        solves.append(fresh.timings.solve * 1000)

    # revision: a fresh knowledge base each time (setup not timed), one observation timed
    def timed_revision(observation: Observation, multishot: bool) -> float:
        times = []
        for _ in range(repeats + 1):
            base = KnowledgeBase(domain)
            base.prior("printer")
            start = time.perf_counter()
            if multishot:
                base.observe(observation)
            else:
                KnowledgeBase(domain, observations=[observation]).prior("printer")
                continue_timer = time.perf_counter()
                times.append(continue_timer - start)
                continue
            base.prior("printer")
            times.append(time.perf_counter() - start)
        return statistics.median(times[1:]) * 1000

    seen = Observation("textbook1", "bedroom")
    revision_ms = timed_revision(seen, multishot=True)
    reground_ms = timed_revision(seen, multishot=False)
    new_object_ms = timed_revision(Observation("printer9", "kitchen", "printer"), multishot=True)
    base = KnowledgeBase(domain)
    before = base.prior("printer").prior
    base.observe(seen)
    after = base.prior("printer").prior
    solve_after_ms = base.timings.solve * 1000

    rows = [
        ("load + validate domains/home.yaml", load_ms, None),
        ("clingo grounding (fresh)", statistics.median(grounds), None),
        ("clingo solving (fresh)", statistics.median(solves), None),
        ("prior end to end (load, ground, solve, Eq. 2-5)", prior_ms, TARGET_PRIOR_MS),
        ("revision, known object seen elsewhere: multi-shot", revision_ms, TARGET_REVISION_MS),
        ("  of which clingo solving", solve_after_ms, None),
        ("revision, same fact: ground afresh instead", reground_ms, None),
        ("revision, a new object (grounds afresh)", new_object_ms, None),
    ]
    lines = [
        "# Knowledge-base prior: domains/home.yaml",
        "",
        f"`python benchmarks/bench_prior.py --repeats {repeats}`; median of {repeats} runs after a warm-up; "
        f"Python {platform.python_version()}, clingo {clingo.__version__}, {platform.machine()}.",
        f"First run: grounding {ground_ms:.2f} ms, solving {solve_ms:.2f} ms.",
        "",
        "| step | ms | target | |",
        "| --- | ---: | ---: | --- |",
    ]
    ok = True
    for name, ms, target in rows:
        verdict = "" if target is None else ("ok" if ms < target else "MISSED")
        ok = ok and (target is None or ms < target)
        lines.append(f"| {name} | {ms:.2f} | {'' if target is None else f'< {target:g}'} | {verdict} |")
    lines += [
        "",
        "Prior for `printer` before and after seeing textbook1 in the bedroom: "
        + ", ".join(f"{r} {before[r]:.3f} -> {after[r]:.3f}" for r in before)
        + ".",
    ]
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(text)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
