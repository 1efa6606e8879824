"""Knowledge bases in ASP (clingo) whose answer sets become room priors (Zhang, Sridharan & Wyatt 2015).

Staged: :func:`load_domain` (YAML -> validated :class:`Domain`) -> :class:`KnowledgeBase` (ground and
solve with clingo; revise with observations) -> :class:`AnswerSet` -> :func:`room_prior` (Eq. 2-5,
pure). :func:`domain_prior` composes them: a validated domain (+ observed facts) -> a
:class:`RoomPrior` with its explanation (:attr:`RoomPrior.terms`). Where the robot itself is:
:func:`robot_rooms` -> :func:`robot_room_prior` -> :func:`spread_over_states` (pure, ``robot.py``).
"""

from beliefloc.knowledge.answer import AnswerSet, Literal, Timings
from beliefloc.knowledge.domain import Domain, domain_from_data, load_domain
from beliefloc.knowledge.prior import DEFAULT_FLOOR, XI, PsiTerm, RoomPrior, room_prior
from beliefloc.knowledge.program import (
    AXIOMS,
    ROBOT_AXIOMS,
    KnowledgeBase,
    Observation,
    domain_prior,
    prior_from_answer,
)
from beliefloc.knowledge.robot import (
    DEFAULT_WEIGHT,
    OUTSIDE,
    ROBOT,
    RobotPrior,
    robot_room_prior,
    robot_rooms,
    spread_over_states,
)

__all__ = [
    "AXIOMS",
    "DEFAULT_FLOOR",
    "DEFAULT_WEIGHT",
    "OUTSIDE",
    "ROBOT",
    "ROBOT_AXIOMS",
    "XI",
    "AnswerSet",
    "Domain",
    "KnowledgeBase",
    "Literal",
    "Observation",
    "PsiTerm",
    "RobotPrior",
    "RoomPrior",
    "Timings",
    "domain_from_data",
    "domain_prior",
    "load_domain",
    "prior_from_answer",
    "robot_room_prior",
    "robot_rooms",
    "room_prior",
    "spread_over_states",
]
