"""Knowledge bases in ASP (clingo) whose answer sets become room priors (Zhang, Sridharan & Wyatt 2015).

Staged: :func:`load_domain` (YAML -> validated :class:`Domain`) -> :class:`KnowledgeBase` (ground and
solve with clingo; revise with observations) -> :class:`AnswerSet` -> :func:`room_prior` (Eq. 2-5,
pure). :func:`domain_prior` composes them: a validated domain (+ observed facts) -> a
:class:`RoomPrior` with its explanation (:attr:`RoomPrior.terms`).
"""

from beliefloc.knowledge.answer import AnswerSet, Literal, Timings
from beliefloc.knowledge.domain import Domain, domain_from_data, load_domain
from beliefloc.knowledge.prior import DEFAULT_FLOOR, XI, PsiTerm, RoomPrior, room_prior
from beliefloc.knowledge.program import (
    AXIOMS,
    KB_DIR,
    KnowledgeBase,
    Observation,
    domain_prior,
    prior_from_answer,
)

__all__ = [
    "AXIOMS",
    "DEFAULT_FLOOR",
    "KB_DIR",
    "XI",
    "AnswerSet",
    "Domain",
    "KnowledgeBase",
    "Literal",
    "Observation",
    "PsiTerm",
    "RoomPrior",
    "Timings",
    "domain_from_data",
    "domain_prior",
    "load_domain",
    "prior_from_answer",
    "room_prior",
]
