"""A plain transcription of Colledanchise et al. 2020, Algorithm 1, function ``Plan`` (lines 16-52).

The reference that ``benchmarks.planning`` times :func:`beliefloc.planning.best_first.plan` against.
It does what the pseudocode says, the straightforward way, with no engineering:

* a node stores its full belief vector ``node.b`` (line 31);
* the open list is a Python list scanned linearly for the least ``f`` (lines 20-25);
* ``NextNodes`` (lines 39-52) materialises every successor belief with dense numpy: for an action
  that moves, ``T_aᵀ b`` (``T`` is the model's CSR matrix, ``T[i, j] = P(s_j | s_i, a)``) normalised;
  for an action that observes, the posterior of every observation ``o``::

      b'_j = b_j O_a[j, o] / p(o | a, b),    p(o | a, b) = Σ_j b_j O_a[j, o]

  with ``O_a[:, o]`` from :meth:`beliefloc.model.ObservationModel.likelihood`;
* ``h = H(b') / (max(b') · p)`` (line 35 with the ``max(b)`` weight of Sec. V-A's text and of the
  authors' code), ``g`` adds the action costs (line 34);
* a successor whose belief equals a belief on the open or the closed list is dropped, as in the
  authors' code. ``tolerance=0`` compares with ``np.array_equal`` (exact, the authors' ``std::find``
  with ``==``); a positive ``tolerance`` accepts ``max_j |b_j - b'_j| <= tolerance`` (beliefloc's
  :func:`~beliefloc.planning.best_first.belief_key` rounds to 2^-30, so 2^-31 compares alike);
* the goal ``max(b) >= threshold`` is tested when a node is popped (line 27).

Two departures, both needed to run it at all: a time limit (the result then says so instead of
pretending success, unlike the authors' watchdog), and observations with ``p(o | a, b) = 0`` are
skipped (their posterior is 0 / 0). ``p`` is the Bayes probability above, as in beliefloc; the
authors' code sums ``P(o | s)`` over the belief's support without weighting it by the belief.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from beliefloc.model import Model

FOUND = "found"
NO_PLAN = "no_plan"
TIME_LIMIT = "time_limit"


@dataclass
class Node:
    b: np.ndarray
    parent: Node | None
    action: int | None
    observation: int | None
    g: float
    h: float

    @property
    def f(self) -> float:
        return self.g + self.h


@dataclass(frozen=True)
class BaselineResult:
    status: str
    """``found``, ``no_plan`` (open list ran empty) or ``time_limit``."""
    plan: list[tuple[str, str | None]]
    """(action, expected observation) pairs; the observation is None for an action that observes nothing."""
    cost: float
    expanded: int
    generated: int
    """Nodes added to the open list (after the duplicate check)."""
    seconds: float


def entropy(b: np.ndarray) -> float:
    support = b[b > 0.0]
    return float(-(support * np.log(support)).sum())


def next_nodes(model: Model, b: np.ndarray) -> tuple[list[np.ndarray], list[tuple[int, int | None]], list[float]]:
    """Lines 39-52: every successor belief, the (action, observation) reaching it, and its probability."""
    beliefs: list[np.ndarray] = []
    acts: list[tuple[int, int | None]] = []
    probs: list[float] = []
    for a, action in enumerate(model.actions):
        predicted = b if action.transition is None else action.transition.T @ b
        if not action.observation.parts:
            beliefs.append(predicted / predicted.sum())
            acts.append((a, None))
            probs.append(1.0)
            continue
        for o in range(action.observation.n_observations):
            weighted = predicted * action.observation.likelihood(o)
            p = float(weighted.sum())
            if p > 0.0:
                beliefs.append(weighted / p)
                acts.append((a, o))
                probs.append(p)
    return beliefs, acts, probs


def _listed(b: np.ndarray, nodes: list[Node], tolerance: float) -> bool:
    if tolerance == 0.0:
        return any(np.array_equal(b, node.b) for node in nodes)
    return any(float(np.max(np.abs(b - node.b))) <= tolerance for node in nodes)


def plan_algorithm1(
    model: Model,
    belief: np.ndarray,
    *,
    threshold: float = 0.95,
    time_limit: float = 60.0,
    tolerance: float = 0.0,
    closed_list: list[Node] | None = None,
) -> BaselineResult:
    """Algorithm 1's ``Plan(belief, closed_list)``; ``closed_list`` is extended in place, as in ``Main``."""
    start = time.perf_counter()
    closed = closed_list if closed_list is not None else []
    initial = Node(belief, None, None, None, 0.0, 0.0)
    open_list = [initial]
    expanded = generated = 0
    while open_list:
        if time.perf_counter() - start > time_limit:
            return BaselineResult(TIME_LIMIT, [], 0.0, expanded, generated, time.perf_counter() - start)
        best = 0
        for i in range(1, len(open_list)):
            if open_list[i].f < open_list[best].f:
                best = i
        front = open_list.pop(best)
        closed.append(front)
        if front.b.max() >= threshold:
            steps = _path(model, front)
            return BaselineResult(FOUND, steps, front.g, expanded, generated, time.perf_counter() - start)
        expanded += 1
        beliefs, acts, probs = next_nodes(model, front.b)
        for b, (a, o), p in zip(beliefs, acts, probs, strict=True):
            if _listed(b, open_list, tolerance) or _listed(b, closed, tolerance):
                continue
            h = entropy(b) / (float(b.max()) * p)
            open_list.append(Node(b, front, a, o, front.g + model.actions[a].cost, h))
            generated += 1
    return BaselineResult(NO_PLAN, [], 0.0, expanded, generated, time.perf_counter() - start)


def _path(model: Model, node: Node) -> list[tuple[str, str | None]]:
    """``GetPath`` (line 28): walk back to the initial node."""
    steps: list[tuple[str, str | None]] = []
    current: Node | None = node
    while current is not None and current.action is not None:
        action = model.actions[current.action]
        observation = None if current.observation is None else action.observation.name(current.observation)
        steps.append((action.name, observation))
        current = current.parent
    return steps[::-1]
