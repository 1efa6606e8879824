"""The vocabulary of object search, in a module with no numeric imports: the metareasoning about
the target's existence, the revisions of the cell belief, the policies' names, and the checks of
the values every search takes.

The command line builds its options and help texts from these names when it starts, before any
command runs; keeping them apart from the search code means its help loads neither numpy nor scipy
nor clingo. The modules that compute import their enums from here; the registry
:data:`beliefloc.object_search.policy.POLICIES` has one entry per :class:`PolicyName` (a test
checks it).
"""

from __future__ import annotations

import enum
import math

from beliefloc.errors import InvalidValueError

COMMIT_THRESHOLD = 0.9
"""An object's belief of being in one room above which ``in(object, room)`` is committed to the KB
(dynamic KB, Algorithm 1 lines 7-10)."""


class Metareasoning(str, enum.Enum):
    """How the search decides whether the target exists at all (Zhang et al. Eq. 10-14): which
    approximation of the Beta meta-density of ``P(E)`` (:mod:`beliefloc.object_search.existence`)."""

    EXPECTATION = "expectation"
    """θ = the Beta's mean α' / (α' + β')."""
    UPPER_BOUND = "upper-bound"
    """θ = a high quantile of the Beta (0.9 in the paper)."""
    SAMPLING = "sampling"
    """Monte-Carlo samples of θ, as many as Eq. 14 asks for."""
    NONE = "none"
    """No metareasoning: the target is assumed to exist (the paper's baseline)."""


class Revision(str, enum.Enum):
    """How a revised knowledge base's new prior meets the observations kept so far
    (:meth:`beliefloc.object_search.posterior.CellBelief.revise`)."""

    REUSE = "reuse"
    """Keep the observation likelihood when the prior changes (the paper's choice)."""
    DISCARD = "discard"
    """Reset the likelihood to 1 when the prior changes (Bayes-correct after a commitment)."""
    TRUST = "trust-factor"
    """Pool the KB's belief and the observations' belief with trust factors (r-norm), ref. [32]."""


class Scenes(str, enum.Enum):
    """How a view's image is analysed (:mod:`beliefloc.object_search.scene`)."""

    PLANNED = "planned"
    """The SP-POMDP: the LL and HL policies choose operators and ROIs (the default with a scene model)."""
    ALL = "all"
    """Every operator on every ROI, the likelier answer at the end (the baseline of planning to see)."""
    FIXED = "fixed"
    """The ``search:`` section's fixed detector and analysis cost (the only choice without a scene model)."""

    @property
    def description(self) -> str:
        """One line for help texts."""
        return _SCENE_DESCRIPTIONS[self]


_SCENE_DESCRIPTIONS = {
    Scenes.PLANNED: "the SP-POMDP plans the operators and ROIs; the default with a scene model",
    Scenes.ALL: "every operator on every ROI",
    Scenes.FIXED: "the search: section's fixed detector; the only choice without a scene model",
}


class PolicyName(str, enum.Enum):
    """Which view to analyse next (:mod:`beliefloc.object_search.policy`)."""

    POMDP = "pomdp"
    GREEDY = "greedy"
    POMDP_ONLY = "pomdp-only"

    @property
    def description(self) -> str:
        """One line for help texts and tables."""
        return _POLICY_DESCRIPTIONS[self]


_POLICY_DESCRIPTIONS = {
    PolicyName.POMDP: "expected entropy reduction per time unit, KB prior",
    PolicyName.GREEDY: "view that best confirms the most likely cell, KB prior",
    PolicyName.POMDP_ONLY: "expected entropy reduction per time unit, uniform prior",
}


def check_time_limit(time_limit: float) -> float:
    """A search's time limit, in simulation time units: a positive number."""
    if not (time_limit > 0 and math.isfinite(time_limit)):
        raise InvalidValueError(f"a time limit must be positive and finite, got {time_limit:g}")
    return time_limit


def check_commit_threshold(threshold: float) -> float:
    """The dynamic KB's commit threshold: in (0.5, 1), so that at most one room passes it."""
    if not 0.5 < threshold < 1.0:
        raise InvalidValueError(f"the commit threshold must be between 0.5 and 1 (exclusive), got {threshold:g}")
    return threshold


def check_fraction(what: str, value: float) -> float:
    """A probability or a fraction: in [0, 1]."""
    if not (0.0 <= value <= 1.0 and math.isfinite(value)):
        raise InvalidValueError(f"{what} must be in [0, 1], got {value:g}")
    return value


def wall_clock(seconds: float | None, timings: bool) -> float | None:
    """A wall-clock time in a JSON record: the value, or None when timings are off (so that
    two runs with the same seed print the same bytes)."""
    return seconds if timings else None
