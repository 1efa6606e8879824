"""Which view to analyse next: the policies of object search, in one registry (Zhang et al. Sec. III-B, Table I).

A policy maps ``(space, b, robot)`` to a view, where ``b`` is the cell belief given that the target
exists (axis: cell) and ``robot`` the cell the robot stands on. Pure numpy, no randomness.

* ``pomdp`` — the VS-POMDP's objective (information gain) against the time it costs, with a
  one-step lookahead: for each view ``v``::

      gain(v) = H(b) - Σ_o p(o | v, b) H(b'_{v,o})       (expected entropy reduction)
      score(v) = gain(v) / (travel · dist(robot, v) + analysis)

  i.e. the expected information per time unit, and the view with the highest score is chosen
  (ties: the nearer view, then the lower index). One step because the belief never moves (T = I)
  and a view's answer is binary: ``H(b'_{v,o})`` has a closed form in two sums per view,
  ``Σ_{i∈v} b_i`` and ``Σ_{i∈v} b_i log b_i``, so every view is scored with two matrix-vector
  products (``views`` is sparse: O(cells x view²) per step). The paper's VS-POMDP plans further
  with a learned convolutional policy kernel [34]; this is a documented simplification.
* ``greedy`` — the baseline heuristic: stand on the currently most likely cell (ties: another cell
  than the robot's, then the nearest).
* ``pomdp-only`` — the ``pomdp`` selection with a uniform prior instead of the knowledge base's
  (the "POMDP only" baseline): the loop reads :attr:`Policy.kb_prior`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from beliefloc.object_search.world import SearchSpace

Select = Callable[[SearchSpace, np.ndarray, int], int]


def _xlogx(x: np.ndarray | float) -> np.ndarray:
    """``x log x`` elementwise, 0 where ``x`` is 0."""
    x = np.asarray(x, dtype=float)
    result = np.zeros_like(x)
    np.log(x, out=result, where=x > 0)
    result *= x
    return result


def expected_entropy(space: SearchSpace, belief: np.ndarray) -> np.ndarray:
    """``Σ_o p(o | v, b) H(b'_{v,o})`` for every view v (nats; axis: view).

    With ``L_in``/``L_out`` the likelihood of ``o`` in and out of view, ``p = Σ_{i∈v} b_i`` and
    ``s = Σ_{i∈v} b_i log b_i``, ``S = Σ_i b_i log b_i``:
    ``p(o) H(b'_o) = p(o) log p(o) - [L_in (s + p log L_in) + L_out (S - s + (1 - p) log L_out)]``.
    """
    return _expected_entropy(space, belief, _xlogx(belief))


def _expected_entropy(space: SearchSpace, belief: np.ndarray, xlogx: np.ndarray) -> np.ndarray:
    p_in = space.views @ belief
    s_in = space.views @ xlogx
    s_all = float(xlogx.sum())
    tp, fp = space.detector.true_positive, space.detector.false_positive
    total = np.zeros(len(p_in))
    for l_in, l_out in ((tp, fp), (1.0 - tp, 1.0 - fp)):
        p_obs = l_in * p_in + l_out * (1.0 - p_in)
        weighted = l_in * s_in + _xlogx(l_in) * p_in + l_out * (s_all - s_in) + _xlogx(l_out) * (1.0 - p_in)
        total += _xlogx(p_obs) - weighted
    return total


def entropy(belief: np.ndarray) -> float:
    return float(-_xlogx(belief).sum())


def _best(scores: np.ndarray, distances: np.ndarray) -> int:
    """The highest score (within 1e-12 of it); ties go to the nearer view, then the lower index."""
    top = np.flatnonzero(scores >= scores.max() - 1e-12)
    return int(top[np.argmin(distances[top])])


def select_pomdp(space: SearchSpace, belief: np.ndarray, robot: int) -> int:
    """Expected entropy reduction per time unit, one step ahead (see the module docstring); only
    view points in rooms the robot can enter."""
    xlogx = _xlogx(belief)
    gain = -float(xlogx.sum()) - _expected_entropy(space, belief, xlogx)
    distances = space.distances_from(robot)
    scores = gain / (space.travel_cost * distances + space.analysis_cost)
    return _best(np.where(space.reachable, scores, -np.inf), distances)


def select_greedy(space: SearchSpace, belief: np.ndarray, robot: int) -> int:
    """Stand on the most likely cell (view v stands on cell v).

    Ties (a positive detection raises every cell of a view alike) go first to a cell other than
    the robot's own -- standing still would repeat a view that cannot split the tied cells --
    then to the nearest, then to the lower index.
    """
    distances = space.distances_from(robot)
    belief = np.where(space.reachable, belief, -1.0)
    top = np.flatnonzero(belief >= belief.max() - 1e-12)
    if len(top) > 1:
        top = top[top != robot]
    return int(top[np.argmin(distances[top])])


@dataclass(frozen=True)
class Policy:
    name: str
    select: Select
    kb_prior: bool
    """False: the search starts from a uniform prior over cells instead of the knowledge base's."""
    description: str


POLICIES: dict[str, Policy] = {
    "pomdp": Policy("pomdp", select_pomdp, True, "expected entropy reduction per time unit, KB prior"),
    "greedy": Policy("greedy", select_greedy, True, "go to the most likely cell, KB prior"),
    "pomdp-only": Policy("pomdp-only", select_pomdp, False, "expected entropy reduction per time unit, uniform prior"),
}
