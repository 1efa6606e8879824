"""One pool of threads per process, for NumPy and compiled passes that release the interpreter's lock.

The planner's successor passes (:mod:`beliefloc.planning.successors`), the ray casting behind the
pose lattice's tables (:mod:`beliefloc.continuous.raycast`) and the scan tables' distributions
(:func:`beliefloc.semantic_map.lattice_sensors.scan_tables`) split their work over it; a process on one
core has none, and does the work in its own thread. A task on the pool must not wait on another
task of it (with every thread waiting, none would run).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:  # this module imports no numpy: it is imported before any command needs it
    import numpy as np

T = TypeVar("T")
U = TypeVar("U")

_POOL: ThreadPoolExecutor | None = None
_POOL_MADE = False
_IN_POOL = threading.local()
"""``_IN_POOL.task`` is true in the pool's own threads."""


def _mark_pool_thread() -> None:
    _IN_POOL.task = True


def pool() -> ThreadPoolExecutor | None:
    """Threads, one per core this process may use (at most four: the passes share the memory bus),
    made once; None on one core."""
    global _POOL, _POOL_MADE
    if not _POOL_MADE:
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
        _POOL = (
            ThreadPoolExecutor(min(4, cores), thread_name_prefix="beliefloc", initializer=_mark_pool_thread)
            if cores > 1
            else None
        )
        _POOL_MADE = True
    return _POOL


def side_by_side(first: Callable[[], T], second: Callable[[], U]) -> tuple[T, U]:
    """``(first(), second())``, ``second`` on :func:`pool` while ``first`` runs in this thread (one
    after the other without a pool, or in a task of the pool, which must not wait on another): two
    halves of a pass, each writing its own part."""
    made = pool()
    if made is None or getattr(_IN_POOL, "task", False):
        return first(), second()
    later = made.submit(second)
    return first(), later.result()


def filled(vector: np.ndarray, value: float) -> np.ndarray:
    """``vector`` (a new one, of 1 MB and more) with ``value`` written over it, its two halves side by
    side. On the virtual machines measured, a page first touched costs ~1-2.5 ms a MB of system time in
    the thread that touches it: a new 80 MB vector first written by one compiled pass took ~0.2 s on
    one core while the other waited, and a 10^7-state search makes eight in its first expansions (its
    cache filling). Two cores fault the same pages in about half the time: a search from the uniform
    belief at 10^7 states 6.9-7.2 s instead of 8.0-8.5 s, the same plan."""
    half = len(vector) // 2
    side_by_side(lambda: vector[:half].fill(value), lambda: vector[half:].fill(value))
    return vector


def size() -> int:
    """How many threads :func:`pool` has (1 without one)."""
    made = pool()
    return 1 if made is None else made._max_workers


def _forget_pool() -> None:
    """In a forked child: the parent's threads did not come along, so its pool would never run a task."""
    global _POOL, _POOL_MADE
    _POOL, _POOL_MADE = None, False


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)
