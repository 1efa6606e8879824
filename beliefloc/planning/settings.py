"""The planners' vocabulary: heuristics, budgets and defaults, in a module with no numeric imports.

The command line builds its options and help texts from these names when it starts, before any
command runs; keeping them apart from the search code means ``beliefloc --help`` loads neither numpy
nor scipy (the planners import them from here).
"""

from __future__ import annotations

import enum
import math

from beliefloc.errors import InvalidValueError

DEFAULT_THRESHOLD = 0.95
"""The goal: one state holds at least this probability (Colledanchise's P̄)."""
DEFAULT_MAX_EXPANSIONS = 200_000
DEFAULT_TIME_LIMIT = 60.0
"""Seconds of search before a planner gives up."""
DEFAULT_WEIGHT = 1.0
"""Best-first search ranks nodes by ``g + weight · h``; 1 is the paper's."""
LOOKAHEAD_WORK = 30_000
"""The contingent strategy's default lookahead: beliefs expanded per plan call, ``LOOKAHEAD_WORK /
|S|`` but at least :data:`MIN_LOOKAHEAD` -- about the same work per call at every size (an
expansion costs O(|S|)): about 900 on the bundled kitchen and hallway, 300 at 10^2 states, 32 from
10^3 states up."""
MIN_LOOKAHEAD = 32


def default_lookahead(n_states: int) -> int:
    """See :data:`LOOKAHEAD_WORK`."""
    return max(MIN_LOOKAHEAD, LOOKAHEAD_WORK // max(1, n_states))


PATH_PROBABILITY_FLOOR = 0.05
"""``plan`` flags a path whose expected observations the robot sees together with less probability
than this (:attr:`beliefloc.planning.best_first.PlanResult.path_probability`): such a path is one
branch of what may happen, not a forecast -- the robot will most likely see something else and plan
again, so its cost is no estimate of what localizing costs (``plan --policy`` gives the expected cost).
One in twenty: below it the path is rarer than the outcome a 95 % threshold leaves out."""

DEFAULT_PRUNE_BELOW = 1e-3
"""Contingent plans: branches reached with less probability than this are not planned for (the robot
plans again if it gets there)."""
DEFAULT_MAX_HYPOTHESES = 400
"""EC2: Khalvati & Mackworth Sec. VII-B's reduction to the most likely states."""


class Planner(str, enum.Enum):
    """How ``plan`` searches: best-first with a heuristic, or uniform-cost (h = 0, least-cost plans)."""

    BESTFIRST = "bestfirst"
    UNIFORM = "uniform"


class Heuristic(enum.Enum):
    """``h`` of best-first search (see :mod:`beliefloc.planning.best_first`)."""

    ENTROPY_MAX_PROB = "entropy-max-prob"
    ENTROPY_PROB = "entropy-prob"
    ZERO = "zero"

    def __call__(self, entropy: float, max_belief: float, probability: float) -> float:
        if self is Heuristic.ZERO:
            return 0.0
        weight = probability * (max_belief if self is Heuristic.ENTROPY_MAX_PROB else 1.0)
        return entropy / weight


class SelectionRule(str, enum.Enum):
    """How ``select`` weighs actions: Khalvati & Mackworth's pairwise edge weights (EC2)."""

    EC2 = "ec2"


def check_weight(weight: float) -> float:
    """The weight of ``h`` in best-first search: a positive finite number."""
    if not (weight > 0.0 and math.isfinite(weight)):
        raise InvalidValueError(f"the weight of h must be a positive number, got {weight:g}; for h = 0 plan uniformly")
    return weight


def heuristic_for(planner: Planner, heuristic: Heuristic | None, weight: float = DEFAULT_WEIGHT) -> Heuristic:
    """The heuristic a planner uses: uniform-cost search is h = 0, so it takes neither another
    heuristic nor a weight (:class:`InvalidValueError` naming the contradiction)."""
    check_weight(weight)
    if planner is Planner.UNIFORM:
        if heuristic not in (None, Heuristic.ZERO):
            raise InvalidValueError("uniform-cost search is the search with h = 0: it takes no other heuristic")
        if weight != DEFAULT_WEIGHT:
            raise InvalidValueError(
                "uniform-cost search is the search with h = 0, so a weight of h has nothing to scale"
            )
        return Heuristic.ZERO
    return heuristic or Heuristic.ENTROPY_MAX_PROB
