"""Which view to analyse next: the policies of object search, in one registry (Zhang et al. Sec. III-B, Table I).
Their names and one-line descriptions are :class:`~beliefloc.object_search.settings.PolicyName`.

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
* ``greedy`` — the baseline heuristic of Table I, "go to the currently most likely cell": assume the
  target is on the most likely cell ``m`` and take the view whose answer, under that assumption,
  raises the belief in ``m`` most in expectation::

      score(v) = Σ_o p(o | target on m, v) · b'(m | v, o)       b'(m | v, o) = p(o | m, v) b_m / p(o | v, b)

  with ``p(present | v, b) = p_FP + (p_TP - p_FP) Σ_{i∈v} b_i`` (ties: the nearest view, then the
  lower index). One step, no travel cost, and ``m``'s belief as the only objective: a greedy
  heuristic. It nearly always picks a view covering ``m`` -- with an informative detector, the one
  with the least competing belief in view, so ``m`` sits at the view's edge, away from the cells
  it is tied with -- and a view that covers ``m``'s competitors but not ``m`` when every view
  covering ``m`` also covers them (a corner cell and its diagonal neighbour, with 3x3 views). The
  first version stood *on* ``m``: a view raises every viewed cell alike, so after a detection ``m``
  and its neighbours rose together, no cell passed τ+ and about 95 % of the trials on ``home.yaml``
  hit the time limit.
With a scene model (:mod:`beliefloc.object_search.scene`) every view has its own ``p_TP``, ``p_FP`` and
expected processing time (``SearchSpace.rates``, ``SearchSpace.analysis_time``); the formulas are the
same, elementwise over views, and a view's analysis time is ``p_in t_in + (1 - p_in) t_out`` with
``p_in = Σ_{i∈v} b_i``.

* ``pomdp-only`` — the ``pomdp`` selection with a uniform prior instead of the knowledge base's
  (the "POMDP only" baseline): the loop reads :attr:`Policy.kb_prior`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from beliefloc.object_search.settings import PolicyName
from beliefloc.object_search.space import SearchSpace

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
    return _entropy_and_mass(space, belief, xlogx)[0]


def _entropy_and_mass(space: SearchSpace, belief: np.ndarray, xlogx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The expected entropy after each view, and each view's belief mass ``Σ_{i∈v} b_i`` (axis: view).
    The detector's rates are numbers, or arrays over views with a scene model (elementwise alike)."""
    p_in = space.views @ belief
    s_in = space.views @ xlogx
    s_all = float(xlogx.sum())
    tp, fp = space.rates()
    total = np.zeros(len(p_in))
    for l_in, l_out in ((tp, fp), (1.0 - tp, 1.0 - fp)):
        p_obs = l_in * p_in + l_out * (1.0 - p_in)
        weighted = l_in * s_in + _xlogx(l_in) * p_in + l_out * (s_all - s_in) + _xlogx(l_out) * (1.0 - p_in)
        total += _xlogx(p_obs) - weighted
    return total, p_in


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
    after, p_in = _entropy_and_mass(space, belief, xlogx)
    gain = -float(xlogx.sum()) - after
    distances = space.distances_from(robot)
    scores = gain / (space.travel_cost * distances + space.analysis_time(p_in))
    return _best(np.where(space.reachable, scores, -np.inf), distances)


def select_greedy(space: SearchSpace, belief: np.ndarray, robot: int) -> int:
    """The view that would most raise the belief in the most likely cell ``m``, were the target there
    (see the module docstring). ``m``: the most likely cell some view covers; ties go to the cell
    nearest the robot, then the lower index."""
    distances = space.distances_from(robot)
    seen = np.asarray(space.views.sum(axis=0)).ravel() > 0  # cells some view covers
    candidate = np.where(seen, belief, -1.0)
    top = np.flatnonzero(candidate >= candidate.max() - 1e-12)
    cell = int(top[np.argmin(distances[top])])
    tp, fp = space.rates()
    covers = space.views[:, [cell]].toarray().ravel() > 0
    like_present = np.where(covers, tp, fp)  # p(present | target on m, v)
    p_present = fp + (tp - fp) * (space.views @ belief)  # p(present | v, b)
    score = np.zeros(len(p_present))
    for like, p_obs in ((like_present, p_present), (1.0 - like_present, 1.0 - p_present)):
        # Σ_o p(o | m, v) · p(o | m, v) b_m / p(o | v, b); an outcome impossible under b has weight 0 under m
        score += np.divide(like * like * belief[cell], p_obs, out=np.zeros(len(p_obs)), where=p_obs > 0)
    return _best(np.where(space.reachable, score, -np.inf), distances)


@dataclass(frozen=True)
class Policy:
    name: PolicyName
    select: Select
    kb_prior: bool
    """False: the search starts from a uniform prior over cells instead of the knowledge base's."""

    @property
    def description(self) -> str:
        return self.name.description


POLICIES: dict[str, Policy] = {
    policy.name.value: policy
    for policy in (
        Policy(PolicyName.POMDP, select_pomdp, True),
        Policy(PolicyName.GREEDY, select_greedy, True),
        Policy(PolicyName.POMDP_ONLY, select_pomdp, False),
    )
}
"""Every policy by its name: one entry per :class:`~beliefloc.object_search.settings.PolicyName`."""
