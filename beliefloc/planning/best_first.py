"""Best-first search in belief space: Colledanchise et al. 2020, Algorithm 1, function ``Plan``.

Nodes are beliefs; an edge is an action and, for an action that observes, one of its observations
with ``p(o | a, b) > 0`` (:mod:`beliefloc.planning.successors`). ``g`` adds the actions' costs. ``h``:

* ``entropy-max-prob`` (default): ``H(b) / (max(b) · p)`` -- Sec. V-A's text and the authors' code;
* ``entropy-prob``: ``H(b) / p`` -- the pseudocode's line 35;
* ``zero``: ``h = 0``, the uniform-cost search of Tables I and II (its plans have the least cost).

``p`` is the probability of the observation that led to the node (1 for an action that observes
nothing). The goal is ``max(b) >= threshold``, tested when a node is popped (line 27).

``f = g + w · h`` with ``w = 1`` as in the paper. ``h = H / (max(b) p)`` grows like ``|S| ln |S|``
while ``g`` is a sum of action costs, so on large maps the search is greedy in ``h`` and ignores
what actions cost; a weight below 1 (Pohl's weighted A*, read the other way) lets ``g`` count:
cheaper plans for a longer search (``benchmarks/results/planning-weight.md`` measures the trade).

Differences from the pseudocode, each for a stated reason:

* **Duplicates** are detected on pop with :func:`belief_key`: beliefs equal to within about 1e-9
  in every entry are one node. Without it, the reachable set of a noise-free world is infinite. In
  the paper's greedy search, a reading that moves the belief by less than :data:`UNINFORMATIVE_READING`
  is the belief just expanded: not pushed at all; nor, when the perception repeats the one that led to
  the belief, a reading that moves it by less than :data:`REPEATED_READING`.
* **Termination is honest, and anytime.** The open list running empty means every reachable belief
  was searched and none is a goal: :attr:`PlanStatus.NO_PLAN`. A budget (expansions, seconds) that
  runs out gives :attr:`PlanStatus.BUDGET_EXCEEDED`, never a fake success -- but not empty-handed:
  the result carries the *best partial plan by its estimate*, the path to the open node of least
  ``f`` (the node the search would have expanded next), marked incomplete (:attr:`PlanResult.complete`
  is false). A robot acts on its first step and plans again (the waiting robot of issue 28). The
  clock is read at every pop, so a call overruns its seconds by at most one pop and one expansion. When
  the budget runs out before the start belief is expanded, the start is expanded anyway (one
  expansion over the budget) and the partial plan is its child of least ``f``.
* **Memory.** A node keeps its parent, action, observation and g -- not its belief, which is
  recomputed from the parent's on pop (parents' beliefs are kept in a bounded cache).
* **The closed list is kept across replans** as a :class:`ClosedList`: the successor statistics of
  every belief already expanded. A replan re-expands such a belief without recomputing them. Unlike
  pruning closed beliefs outright (the authors' code), this keeps the search complete.
"""

from __future__ import annotations

import enum
import heapq
import math
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np
import xxhash

from beliefloc.model import Model
from beliefloc.planning import successors
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Heuristic,
    check_weight,
)
from beliefloc.planning.successors import SuccessorEvaluator, SuccessorStats
from beliefloc.source import threads
from beliefloc.source.located import gc_paused

KEY_RESOLUTION = 2**30
"""Beliefs are compared after rounding every entry to a multiple of 2^-30 (about 1e-9)."""
UNINFORMATIVE_READING = 1e-6
"""A perception's reading that moves the belief by less than this in L1 (``Σ_j |b'_j - b_j|``,
:attr:`SuccessorStats.change`) gives the belief just expanded: the child is not pushed (unless it is a
goal). On noisy looks, the likeliest reading of a look repeated at one spot moves the belief ~100 times
less each time, and the key told those beliefs apart until the 4th-6th repeat: runs of expansions whose
``h`` did not move (10^7 states: 53 expansions, 43 with this rule; 10^6: 26, 24). On the paper's worlds
the same plans: 1,276 plans from beliefs reached by random actions (10^2-10^4 states, 16 % fewer
expansions) and the 320 best-first episodes of Tables I-II (10^2-10^5). Only the paper's
greedy search (``weight >= 1`` and an entropy estimate) skips such readings: the least-cost searches keep
them all, because at 10^2 states one uniform-cost plan of 444 was dearer without them (7 -> 12: a look
repeated five times, then a rare reading, whose update divides the tiny differences by its small
probability)."""
REPEATED_READING = 1e-3
"""The bar of :data:`UNINFORMATIVE_READING` for a perception that repeats the one that led to the belief
(nothing done between: the robot looks again at the same spot). A noisy look's likeliest reading moves the
belief ~100 times less at each repeat (a trace at 10^6 states: changes of 0.03-0.06 at the second look,
3e-4 to 6e-4 at the third, 3e-6 to 6e-6 at the fourth), so the third look is not searched: 10^7 states 43 ->
35 expansions, 10^6 24 -> 19, the same plans; on the paper's worlds the same plans from 1,060 beliefs
reached by random actions (10^2-10^4 states) with 20-22 % fewer expansions; on the scan-only depot
corridor, 50 episodes of 0.4 s plan calls side by side with the code before, a mean cost of 67.8 against
73.8 and no episode at the step limit against two (``benchmarks/results/real-floors.md``). Like
:data:`UNINFORMATIVE_READING`, only in the greedy search; a perception that would need hundreds of
repeats, each moving the belief by less than this, is not searched."""
_CACHE_BYTES = 256 * 2**20
_CACHE_MIN_BELIEFS = 16
"""The belief cache holds :data:`_CACHE_BYTES` of small beliefs, and never fewer than this many."""
_CACHE_LARGE_BELIEFS = 8
"""Beliefs the search recycles (:data:`_RECYCLE_BYTES` and more): this many. Each is memory faulted in once,
which on a virtual machine whose host backs memory at first touch costs 2-10 ms a MB, while a belief made
again from its parent costs 0.3-0.5 ms a MB: a cached belief pays only if it spares ten recomputations. At
10^7 states (80 MB a belief) four were too few (a pop recomputed a chain of 2.5 Bayes updates on average);
eight recomputed as many as thirteen from the uniform belief and five of seven other starts (the other two:
109 and 29 Bayes updates against 85 and 20), and a search from the uniform belief in a fresh process took
10.1-10.9 s instead of 12.8. At 10^6 states, eight against sixteen from 16 starts: as many Bayes updates
from 14 (the others 3 and 4 more), 0.05-0.26 s less system time and faster searches from 15 (0.43-1.15 s
against 0.49-1.26 s)."""


_RECYCLE_BYTES = 2**20
"""Beliefs of at least this size (131,072 states) that the search lets go are handed back to the
evaluator to be written over (:meth:`SuccessorEvaluator.recycle`); smaller ones are left to malloc."""


SearchProgress = Callable[[int, int, float], None]
"""``progress(expanded, generated, seconds)`` during a search."""
_PROGRESS_EVERY = 256


class PlanStatus(enum.Enum):
    FOUND = "found"
    NO_PLAN = "no_plan"
    """Every reachable belief was searched; none reaches the threshold (beliefs of one :func:`belief_key` are
    one, and in the greedy search a reading that moves a belief by less than :data:`UNINFORMATIVE_READING`,
    or by less than :data:`REPEATED_READING` when its perception repeats the one before, tells nothing)."""
    BUDGET_EXCEEDED = "budget_exceeded"
    """The expansion or time budget ran out first; a plan may or may not exist."""


class KeyWork:
    """Scratch vectors for :func:`belief_key`, reused across the keys of one search."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.scaled = np.empty(shape)
        self.whole = np.empty(shape, dtype=np.int32)


def _digest(data: memoryview) -> bytes:
    """The 128-bit digest of a key's bytes: XXH3-128 (``xxhash``).

    A key only has to tell beliefs apart within one process (the closed list): no file, no message and no
    other process sees it, so it needs a digest without accidental collisions, not one that resists an
    attacker. XXH3-128 passes SMHasher's collision and distribution tests; for N distinct beliefs the
    chance that two of them share a digest is about N² / 2^129, under 10^-26 for the million keys a
    closed list holds at most (:attr:`ClosedList.max_entries`). A collision would merge two beliefs of
    the search into one node -- a plan found later, or not at all -- never a belief or a declaration
    (those come from the Bayes updates, not from keys). And only a model file made for the purpose could
    aim at one: it would have to make two reachable beliefs whose 4-40 MB of rounded entries collide.
    XXH3 reads 4 MB (10^6 states) in 0.04 ms in the cache and 40 MB in ~1 ms from memory, against
    1.9 and 19 ms for SHA-256 (in hardware here; BLAKE2b 2.8 and 28 ms): a key a pop, 0.05 s of a 10^6
    plan and ~1 s of a 10^7 one."""
    return xxhash.xxh3_128_digest(data)


def belief_key(belief: np.ndarray, work: KeyWork | None = None, peak: float | None = None) -> bytes:
    """The one duplicate-detection key: entries rounded to multiples of 2^-30, hashed in state order.

    Two beliefs get one key exactly when every rounded entry is equal (up to a 128-bit hash
    collision: :func:`_digest`). The rounded values are whole numbers from 0 to 2^30, so as 32-bit
    integers they are exact (and -0.0 becomes 0): half the bytes of the floats. No gather of the
    support. A vector with an entry above 1 (no belief) is hashed as floats. Keys live in one
    process only (the closed list, :class:`ClosedList`). ``work``, of the belief's shape, holds the
    rounded entries instead of two new arrays; with ``peak``, the belief's maximum, they are rounded
    straight into 32-bit integers when the largest fits (rounding and scaling keep the order of the
    entries, so the largest rounded entry is the rounded peak)."""
    if work is not None and work.scaled.shape == belief.shape:
        if peak is not None and float(np.rint(peak * KEY_RESOLUTION)) <= KEY_RESOLUTION:
            np.multiply(belief, KEY_RESOLUTION, out=work.scaled)
            np.rint(work.scaled, out=work.whole, casting="unsafe")  # whole numbers up to 2^30: exact in 32 bits
            return _digest(work.whole.data)
        scaled = np.multiply(belief, KEY_RESOLUTION, out=work.scaled)
    else:
        scaled = belief * KEY_RESOLUTION
    np.rint(scaled, out=scaled)
    if scaled.size and not float(scaled.max()) <= KEY_RESOLUTION:
        scaled += 0.0  # -0.0 + 0.0 is 0.0: an entry rounded to zero has one byte pattern
        return b"f" + _digest(scaled.data)
    if work is not None and scaled is work.scaled:
        np.copyto(work.whole, scaled, casting="unsafe")  # what astype(np.int32) does, into the buffer
        return _digest(work.whole.data)
    return _digest(scaled.astype(np.int32).data)


_KEY_BLOCK = 2**15
"""Entries :func:`key_and_peak` rounds at a time."""


def key_and_peak(belief: np.ndarray, work: KeyWork) -> tuple[bytes, float]:
    """``(belief_key(belief, work, peak), peak)`` with ``peak = float(belief.max())``, the same key and
    maximum, in one sweep: block by block, each block scaled into a small buffer (in the cache), rounded
    into the 32-bit entries and its maximum taken, instead of a pass for the maximum, one writing the
    scaled vector and one reading it back. When the maximum does not round into 32 bits (no belief), the
    key is made again by :func:`belief_key`."""
    n = belief.size
    if (
        work.scaled.shape != belief.shape
        or belief.ndim != 1
        or not n
        or belief.dtype != np.float64
        or not belief.flags.c_contiguous
    ):
        peak = float(belief.max())
        return belief_key(belief, work, peak), peak
    if successors.fused is not None:  # the same rounding in one compiled pass (halves on two cores)
        peak, fits = _fused_round_key(successors.fused, belief, work.whole)
        if fits and float(np.rint(peak * KEY_RESOLUTION)) <= KEY_RESOLUTION:
            return _digest(work.whole.data), peak
    maxima = np.empty((n + _KEY_BLOCK - 1) // _KEY_BLOCK)
    with np.errstate(invalid="ignore"):  # a NaN entry (no belief) cast to an integer: the key is made again
        for index, start in enumerate(range(0, n, _KEY_BLOCK)):
            block = belief[start : start + _KEY_BLOCK]
            scaled = np.multiply(block, KEY_RESOLUTION, out=work.scaled[: len(block)])
            np.rint(scaled, out=work.whole[start : start + len(block)], casting="unsafe")
            maxima[index] = np.maximum.reduce(block)  # block.max() without its Python wrapper
    peak = float(maxima.max())  # the belief's maximum (a NaN entry makes it NaN, as belief.max() does)
    if not float(np.rint(peak * KEY_RESOLUTION)) <= KEY_RESOLUTION:
        return belief_key(belief, work, peak), peak
    return _digest(work.whole.data), peak


def _fused_round_key(compiled: ModuleType, belief: np.ndarray, whole: np.ndarray) -> tuple[float, bool]:
    """``compiled.round_key`` (each entry rounded on its own), the two halves side by side on
    :func:`beliefloc.source.threads.pool`: the same entries, the larger maximum (at 10^7 states 12 ms a key
    on one core)."""
    n = belief.size
    if n <= successors.SPLIT_FROM:
        peak, fits = compiled.round_key(belief, KEY_RESOLUTION, whole)
        return float(peak), bool(fits)
    half = n // 2
    (peak, fits), (peak_high, fits_high) = threads.side_by_side(
        lambda: compiled.round_key(belief[:half], KEY_RESOLUTION, whole[:half]),
        lambda: compiled.round_key(belief[half:], KEY_RESOLUTION, whole[half:]),
    )
    return max(float(peak), float(peak_high)), bool(fits) and bool(fits_high)


@dataclass(frozen=True)
class PlanStep:
    action: str
    observation: str | None
    """The observation expected after the action (None when the action observes nothing)."""
    probability: float
    """``p(o | a, b)`` of that observation."""
    max_belief: float
    """``max(b)`` of the belief expected after the step."""
    cost: float
    """Cumulative cost up to and including this step."""
    action_index: int
    observation_index: int | None


@dataclass(frozen=True, eq=False)
class PlanResult:
    status: PlanStatus
    steps: tuple[PlanStep, ...]
    belief: np.ndarray | None
    """The belief the plan is expected to reach (None unless FOUND, also for a partial plan)."""
    expanded: int
    generated: int
    seconds: float

    @property
    def found(self) -> bool:
        return self.status is PlanStatus.FOUND

    @property
    def complete(self) -> bool:
        """The steps reach the goal; false for the partial plan of a search out of budget (and for
        no plan)."""
        return self.found

    @property
    def partial(self) -> bool:
        """The budget ran out and :attr:`steps` is the best partial plan by its estimate."""
        return self.status is PlanStatus.BUDGET_EXCEEDED and bool(self.steps)

    @property
    def cost(self) -> float:
        return self.steps[-1].cost if self.steps else 0.0

    @property
    def path_probability(self) -> float:
        """The probability that the robot sees every expected observation of :attr:`steps` when it
        does their actions from the start belief: ``Π p(o_k | a_k, b_{k-1})`` by the chain rule (1 for
        no steps, and each action that observes nothing counts 1). A plan shown as "the" plan is a
        hope, not a forecast, when this is small (:data:`~beliefloc.planning.settings.PATH_PROBABILITY_FLOOR`)."""
        return math.prod(step.probability for step in self.steps)

    def as_json(self, model: Model) -> dict[str, Any]:
        """What ``plan --json`` prints: the status, the steps with their expected observations, the
        search's effort, and ``"pose"``: the pose of the most likely state of the belief the plan is
        expected to reach (:attr:`belief`) with that belief's covariance
        (:meth:`beliefloc.pose.PoseEstimate.as_json`); null without a plan or for a model without
        a grid. ``"complete"`` is false when the budget ran out (the steps are then the best partial
        plan, the first the action to take now); ``"path_probability"`` is :attr:`path_probability`,
        and each step's ``"probability"`` is ``p(o | a, b)`` of its observation (1 without one)."""
        from beliefloc.pose import pose_json

        return {
            "found": self.found,
            "status": self.status.value,
            "complete": self.complete,
            "cost": self.cost if self.found else None,
            "path_probability": self.path_probability,
            "steps": [
                {
                    "action": s.action,
                    "observation": s.observation,
                    "probability": s.probability,
                    "max_belief": s.max_belief,
                    "cost": s.cost,
                }
                for s in self.steps
            ],
            "pose": None if self.belief is None else pose_json(model, self.belief),
            "expanded": self.expanded,
            "generated": self.generated,
            "seconds": self.seconds,
        }


@dataclass
class ClosedList:
    """The closed list kept across replans: successor statistics of every expanded belief."""

    successors: dict[bytes, list[SuccessorStats]] = field(default_factory=dict)
    max_entries: int = 1_000_000

    def remember(self, key: bytes, stats: list[SuccessorStats]) -> None:
        if len(self.successors) < self.max_entries:
            self.successors[key] = stats


def cache_capacity(belief_bytes: int) -> int:
    """How many beliefs of ``belief_bytes`` a search keeps (:data:`_CACHE_MIN_BELIEFS`, :data:`_CACHE_LARGE_BELIEFS`).
    Beliefs the search recycles: few, their evictions written over; more were fresh memory to fault in."""
    if belief_bytes >= _RECYCLE_BYTES:
        return _CACHE_LARGE_BELIEFS
    return max(_CACHE_MIN_BELIEFS, _CACHE_BYTES // max(1, belief_bytes))


def plan(
    model: Model,
    belief: np.ndarray,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    heuristic: Heuristic = Heuristic.ENTROPY_MAX_PROB,
    max_expansions: int = DEFAULT_MAX_EXPANSIONS,
    time_limit: float = DEFAULT_TIME_LIMIT,
    memory: ClosedList | None = None,
    evaluator: SuccessorEvaluator | None = None,
    weight: float = DEFAULT_WEIGHT,
    progress: SearchProgress | None = None,
) -> PlanResult:
    """Search for actions that take ``belief`` to one with ``max(b) >= threshold``.

    Nodes are ranked by ``f = g + weight · h`` (``weight > 0``; 1 is the paper's search).
    ``progress(expanded, generated, seconds)`` is called every few hundred expansions."""
    check_weight(weight)
    # A search allocates millions of open-list entries and node records but no reference cycles; full
    # passes of the cyclic collector over them took up to 0.4 s each on the 24,796-state corridor (a
    # plan call with a 0.4 s budget ran 1.3 s)
    with gc_paused():
        return _search(
            model, belief, threshold, heuristic, max_expansions, time_limit, memory, evaluator, weight, progress
        )


def _search(
    model: Model,
    belief: np.ndarray,
    threshold: float,
    heuristic: Heuristic,
    max_expansions: int,
    time_limit: float,
    memory: ClosedList | None,
    evaluator: SuccessorEvaluator | None,
    weight: float,
    progress: SearchProgress | None,
) -> PlanResult:
    start = time.perf_counter()
    evaluator = evaluator or SuccessorEvaluator(model)
    memory = memory if memory is not None else ClosedList()
    # node records, by node id
    parent: list[int] = [-1]
    action_of: list[int] = [-1]
    observation_of: list[int | None] = [None]
    g_of: list[float] = [0.0]
    stats_of: list[SuccessorStats | None] = [None]
    # the beliefs of the last expanded node's children that are its predictions (actions that observe
    # nothing): a greedy search pops one of them next, and computing it again cost a prediction
    fresh: dict[int, np.ndarray] = {}

    def evicted(old: np.ndarray) -> None:
        # a belief out of the cache and not a fresh child is referred to by nothing: the evaluator
        # writes a later belief into it (no new 8-80 MB array, no page faults)
        if not any(old is kept for kept in fresh.values()):
            evaluator.recycle(old)

    # small beliefs come from malloc's free lists without page faults: not worth the bookkeeping
    recycling = belief.nbytes >= _RECYCLE_BYTES
    cache = BeliefCache(cache_capacity(belief.nbytes), evicted if recycling else None)
    cache.put(0, belief)

    def known(node: int) -> np.ndarray | None:
        found = cache.get(node)
        if found is None and (found := fresh.get(node)) is not None:
            cache.put(node, found)
        return found

    def belief_of(node: int) -> np.ndarray:
        chain = []
        while (cached := known(node)) is None:
            chain.append(node)
            node = parent[node]
        current = cached
        for child in reversed(chain):
            current = evaluator.successor(current, action_of[child], observation_of[child])
            cache.put(child, current)
        return current

    root_h = heuristic(*evaluator.entropy_max(belief), 1.0)
    open_heap: list[tuple[float, float, int, int]] = [(root_h, root_h, 0, 0)]
    closed: set[bytes] = set()
    # the least-cost searches (h = 0, or g weighed against a small w·h) keep every reading (UNINFORMATIVE_READING,
    # REPEATED_READING)
    skip_uninformative = heuristic is not Heuristic.ZERO and weight >= DEFAULT_WEIGHT
    key_work = KeyWork(belief.shape) if recycling else None  # small beliefs: new arrays cost less than ufunc calls
    expanded = 0
    status = PlanStatus.NO_PLAN
    goal = -1
    while open_heap:
        _, _, _, node = heapq.heappop(open_heap)
        # the clock is read at every pop, duplicates too: a run of popped duplicates (each one
        # a Bayes update to recompute) must not overrun a waiting robot's budget
        out_of_time = time.perf_counter() - start > time_limit
        current = belief_of(node)
        # the maximum with the key only where the key uses it: most pops of a long search are duplicates
        peak: float | None = None
        if key_work is not None:
            key, peak = key_and_peak(current, key_work)
        else:
            key = belief_key(current)
        if key in closed:
            if out_of_time:
                status, goal = PlanStatus.BUDGET_EXCEEDED, node  # a cheapest path, to a belief seen before
                break
            continue
        closed.add(key)
        if (current.max() if peak is None else peak) >= threshold:
            status, goal = PlanStatus.FOUND, node
            break
        if expanded >= max_expansions or out_of_time:
            status, goal = PlanStatus.BUDGET_EXCEEDED, node
            break
        expanded += 1
        if progress is not None and expanded % _PROGRESS_EVERY == 0:
            progress(expanded, len(parent) - 1, time.perf_counter() - start)
        # the last expansion's child kept for this pop, if another was popped (a duplicate, a node of the
        # open list), handed back before this expansion's predictions are made: one is written into it
        for old in fresh.values() if recycling else ():
            if not cache.holds(old):
                evaluator.recycle(old)
        fresh = {}
        successors = memory.successors.get(key)
        whole: dict[int, np.ndarray] = {}
        if successors is None:
            successors = evaluator.evaluate(current, whole)
            memory.remember(key, successors)
        for stats in successors:
            bar = REPEATED_READING if stats.action == action_of[node] else UNINFORMATIVE_READING
            uninformative = stats.change is not None and stats.change < bar
            if skip_uninformative and uninformative and stats.max_belief < threshold:
                continue  # the belief just expanded, again (a closed node)
            child = len(parent)
            if stats.observation is None and stats.action in whole:
                fresh[child] = whole[stats.action]
            parent.append(node)
            action_of.append(stats.action)
            observation_of.append(stats.observation)
            g = g_of[node] + model.actions[stats.action].cost
            g_of.append(g)
            stats_of.append(stats)
            h = weight * heuristic(stats.entropy, stats.max_belief, stats.probability)
            heapq.heappush(open_heap, (g + h, h, child, child))
        if recycling:
            # only the child popped next is likely to use its prediction: the others handed back now, so that
            # a Bayes update made at the next pop is written into one of them (at 10^7 states the search's
            # peak was its cached beliefs, four predictions and a look's update: 150 MB of fresh memory less)
            for child in [child for child in fresh if child != open_heap[0][3]]:
                evaluator.recycle(fresh.pop(child))
    if status is PlanStatus.BUDGET_EXCEEDED and goal == 0:
        # out of budget before the start was expanded: expand it anyway, and take its best child
        successors = memory.successors.get(belief_key(belief))
        if successors is None:
            successors = evaluator.evaluate(belief)
            memory.remember(belief_key(belief), successors)
        expanded += 1
        best_f, chosen = math.inf, None
        for stats in successors:
            g = model.actions[stats.action].cost
            f = g + weight * heuristic(stats.entropy, stats.max_belief, stats.probability)
            if f < best_f:
                best_f, chosen = f, stats
        if chosen is not None:
            goal = len(parent)
            parent.append(0)
            action_of.append(chosen.action)
            observation_of.append(chosen.observation)
            g_of.append(model.actions[chosen.action].cost)
            stats_of.append(chosen)
    seconds = time.perf_counter() - start
    if status is PlanStatus.NO_PLAN or (status is PlanStatus.BUDGET_EXCEEDED and goal <= 0):
        return PlanResult(status, (), None, expanded, len(parent) - 1, seconds)
    path = []
    node = goal
    while node != 0:
        path.append(node)
        node = parent[node]
    steps = []
    for node in reversed(path):
        step_stats = stats_of[node]
        assert step_stats is not None
        stats = step_stats
        act = model.actions[stats.action]
        observation = None if stats.observation is None else act.observation.name(stats.observation)
        steps.append(
            PlanStep(
                act.name,
                observation,
                stats.probability,
                stats.max_belief,
                g_of[node],
                stats.action,
                stats.observation,
            )
        )
    reached = belief_of(goal) if status is PlanStatus.FOUND else None
    return PlanResult(status, tuple(steps), reached, expanded, len(parent) - 1, seconds)


class BeliefCache:
    """Least-recently-used beliefs of popped nodes, bounded in count; ``on_evict`` is given each
    belief that leaves."""

    def __init__(self, capacity: int, on_evict: Callable[[np.ndarray], None] | None = None) -> None:
        self.capacity = capacity
        self._items: OrderedDict[int, np.ndarray] = OrderedDict()
        self._on_evict = on_evict
        self._held: dict[int, int] = {}
        """How many cached entries are each array (by ``id``)."""

    def holds(self, belief: np.ndarray) -> bool:
        """Whether this very array is one of the cached beliefs (known with ``on_evict`` only)."""
        return id(belief) in self._held

    def get(self, node: int) -> np.ndarray | None:
        item = self._items.get(node)
        if item is not None:
            self._items.move_to_end(node)
        return item

    def put(self, node: int, belief: np.ndarray) -> None:
        tracking = self._on_evict is not None  # what is held, by id: only to hand back what leaves
        if tracking and (previous := self._items.get(node)) is not None:
            self._release(previous)
        self._items[node] = belief
        self._items.move_to_end(node)
        if tracking:
            self._held[id(belief)] = self._held.get(id(belief), 0) + 1
        if len(self._items) > self.capacity:
            # never evict the root: every chain of recomputation ends there
            oldest = next(iter(self._items))
            if oldest == 0:
                self._items.move_to_end(0)
                oldest = next(iter(self._items))
            gone = self._items.pop(oldest)
            if self._on_evict is not None:
                self._release(gone)
                if id(gone) not in self._held:
                    self._on_evict(gone)

    def _release(self, belief: np.ndarray) -> None:
        count = self._held[id(belief)] - 1
        if count:
            self._held[id(belief)] = count
        else:
            del self._held[id(belief)]
