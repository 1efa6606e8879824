"""Knowledge bases in ASP (clingo) whose answer sets become room priors (Zhang, Sridharan & Wyatt 2015).

Staged: :func:`load_domain` (YAML -> validated :class:`Domain`) -> :class:`KnowledgeBase` (ground and
solve with clingo; revise with observations) -> :class:`AnswerSet` -> :func:`room_prior` (Eq. 2-5,
pure). :func:`domain_prior` composes them: a validated domain (+ observed facts) -> a
:class:`RoomPrior` with its explanation (:attr:`RoomPrior.terms`). Where the robot itself is:
:func:`robot_rooms` -> :func:`robot_room_prior` -> :func:`spread_over_states` (pure, ``robot.py``),
composed by :func:`domain_robot_prior` and :func:`robot_start_belief` (``robot_start.py``).
"""

from beliefloc.knowledge.answer import AnswerSet, Literal, Timings
from beliefloc.knowledge.domain import Domain, domain_from_data, load_domain
from beliefloc.knowledge.prior import DEFAULT_FLOOR, XI, PsiTerm, RoomPrior, room_prior
from beliefloc.knowledge.program import (
    AXIOMS,
    ROBOT_AXIOMS,
    KnowledgeBase,
    KnowledgeBaseSummary,
    Observation,
    domain_prior,
    room_prior_from_answer,
)
from beliefloc.knowledge.robot import (
    DEFAULT_WEIGHT,
    OUTSIDE,
    ROBOT,
    DomainRobotPrior,
    RobotPrior,
    RobotStartBelief,
    check_weight,
    robot_prior_from_answer,
    robot_room_prior,
    robot_rooms,
    spread_over_states,
)
from beliefloc.knowledge.robot_start import domain_robot_prior, robot_start_belief

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
    "DomainRobotPrior",
    "KnowledgeBase",
    "KnowledgeBaseSummary",
    "Literal",
    "Observation",
    "PsiTerm",
    "RobotPrior",
    "RobotStartBelief",
    "RoomPrior",
    "Timings",
    "check_weight",
    "domain_from_data",
    "domain_prior",
    "domain_robot_prior",
    "load_domain",
    "robot_prior_from_answer",
    "robot_room_prior",
    "robot_rooms",
    "robot_start_belief",
    "room_prior",
    "room_prior_from_answer",
    "spread_over_states",
]
