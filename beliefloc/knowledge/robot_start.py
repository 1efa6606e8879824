"""Where the robot starts, from a domain's knowledge base: its room prior with the cells of the
domain's map (:func:`domain_robot_prior`), and a start belief over a model's states
(:func:`robot_start_belief`).

These compose the stages: :class:`~beliefloc.knowledge.program.KnowledgeBase` (clingo) -> an
:class:`~beliefloc.knowledge.answer.AnswerSet` -> the pure rule of :mod:`beliefloc.knowledge.robot`.
Nothing is printed: what a user should be warned about (clingo's warnings, how the prior was made)
comes back with the result. Values that do not fit raise :class:`~beliefloc.errors.InvalidValueError`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from beliefloc.errors import InvalidValueError
from beliefloc.knowledge.domain import Domain, room_mismatch
from beliefloc.knowledge.program import KnowledgeBase, Observation
from beliefloc.knowledge.robot import (
    DEFAULT_WEIGHT,
    OUTSIDE,
    DomainRobotPrior,
    RobotPrior,
    RobotStartBelief,
    robot_prior_from_answer,
    spread_over_states,
)

if TYPE_CHECKING:
    from beliefloc.model import Model
    from beliefloc.semantic_map import SemanticMap


def domain_weight(domain: Domain) -> float:
    """w of the domain: its ``robot.weight``, else :data:`DEFAULT_WEIGHT`."""
    return domain.robot.weight if domain.robot is not None else DEFAULT_WEIGHT


def map_cells(smap: SemanticMap) -> dict[str, int]:
    """Room -> its free cells on ``smap``, and :data:`OUTSIDE` -> the free cells in no room (when any)."""
    cells = {room: int(mask.sum()) for room, mask in smap.rooms.items()}
    free = int(smap.free.sum())
    in_rooms = sum(cells.values())
    if in_rooms < free:
        cells[OUTSIDE] = free - in_rooms
    return cells


def domain_robot_prior(
    domain: Domain,
    *,
    observations: Iterable[Observation] = (),
    kb_files: Sequence[Path] = (),
    use_defaults: bool = True,
    weight: float | None = None,
) -> DomainRobotPrior:
    """The robot's room prior from ``domain``'s knowledge base (+ observed facts), over the rooms
    and, when the domain references a map, its free cells in no room (:data:`OUTSIDE`).

    ``weight`` is w (default: :func:`domain_weight`); raises :class:`InvalidValueError` when it is
    not in (0, 1] (:func:`~beliefloc.knowledge.robot.check_weight`).
    """
    base = KnowledgeBase(domain, kb_files, observations, use_defaults=use_defaults)
    smap = domain.semantic_map
    cells = map_cells(smap) if smap is not None else None
    answer = base.answer()
    prior = robot_prior_from_answer(
        answer,
        weight=domain_weight(domain) if weight is None else weight,
        outside=cells is not None and OUTSIDE in cells,
    )
    return DomainRobotPrior(prior, cells, answer.last_step, _warnings(base, prior))


def robot_start_belief(model: Model, domain: Domain, smap: SemanticMap | None = None) -> RobotStartBelief:
    """The start belief over ``model``'s states from ``domain``'s robot prior: each room's share
    spread over its states (:func:`~beliefloc.knowledge.robot.spread_over_states`).

    ``smap`` is the map whose cells give each room's states (default: the map ``model`` was
    compiled from, :func:`beliefloc.files.model_sources.source_map`); the domain may reference another
    copy of it. Raises :class:`InvalidValueError` when the map has no rooms, when the domain's
    rooms are not the map's, or when the map does not fit the model; :class:`ModelError` when the
    model has no map.
    """
    from beliefloc.files.model_sources import source_map
    from beliefloc.semantic_map import room_states

    smap = smap if smap is not None else source_map(model)
    label = smap.source.path if smap.source is not None else smap.name
    if not smap.rooms:
        raise InvalidValueError(f"{label} has no rooms, so the knowledge base's rooms have no cells there")
    extra, missing = room_mismatch(domain.rooms, smap.rooms)
    if extra or missing:
        parts = [f"not rooms of the map: {', '.join(extra)}"] if extra else []
        parts += [f"rooms of the map the domain lacks: {', '.join(missing)}"] if missing else []
        raise InvalidValueError(f"the domain's rooms must be those of {label}; " + "; ".join(parts))
    assert model.grid is not None  # a map's model always has one (source_map checks it too)
    try:
        states = room_states(smap.rooms, model.grid)
    except ValueError as exc:
        raise InvalidValueError(f"{label} does not fit model {model.name!r}: {exc}") from None
    base = KnowledgeBase(domain)
    covered = sum(len(s) for s in states.values())
    prior = robot_prior_from_answer(base.answer(), weight=domain_weight(domain), outside=covered < model.n_states)
    belief = spread_over_states(prior, states, model.n_states)
    return RobotStartBelief(belief, prior, _warnings(base, prior))


def _warnings(base: KnowledgeBase, prior: RobotPrior) -> tuple[str, ...]:
    """clingo's warnings, then how the prior was made."""
    return (*(f"clingo: {message}" for message in base.warnings), *([prior.message] if prior.message else []))
