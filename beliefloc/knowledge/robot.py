"""Where the robot probably is: from an answer set to a room prior, and from that to a start belief.

Pure functions: no clingo, no I/O. The knowledge base speaks about the robot in its own vocabulary
(``kb/robot.lp``): "the robot is usually at its dock" is a default, "it was last seen in the study"
a fact, "it was carried off its dock" an exception. What it concludes is read at the answer set's
last step, ``holds(in(robot, R), I)``, and turned into a start belief by this rule:

* the rooms ``B`` where ``holds(in(robot, R), last)`` holds share the weight ``w`` equally
  (``w = 0.9`` unless the domain says otherwise), ``w / |B|`` each;
* the other rooms ``O`` share ``1 - w`` equally, ``(1 - w) / |O|`` each; the free cells of the map
  that are in no room count as one more of the other rooms (:data:`OUTSIDE`);
* each room's share is spread uniformly over its cells and headings:
  ``b(s) = prior[room(s)] / |states of room(s)|``.

When every room is in ``B`` they share everything; when ``B`` is empty (the knowledge base does not
say where the robot is) every room gets the same share and the prior says so (:attr:`RobotPrior.message`).
With ``w < 1`` no room is ruled out: a knowledge base that is wrong slows localization down but
cannot make an observation impossible. A room of the prior with no cells on the map is an error.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from beliefloc.errors import InvalidValueError
from beliefloc.knowledge.answer import AnswerSet

ROBOT = "robot"
"""The constant naming the robot in the knowledge base (reserved: no room, class or object has it)."""
DEFAULT_WEIGHT = 0.9
"""w: the share of the start belief on the rooms the knowledge base puts the robot in."""
OUTSIDE = "(no room)"
"""The free cells of a map that are in no room, as one more region of the prior."""


@dataclass(frozen=True)
class RobotPrior:
    """The prior over rooms of where the robot is, with what it came from."""

    rooms: tuple[str, ...]
    """Every room, in the knowledge base's order; :data:`OUTSIDE` last when the map has cells in no room."""
    prior: dict[str, float]
    """Room -> probability; sums to 1."""
    believed: tuple[str, ...]
    """The rooms where the knowledge base says the robot is (``holds(in(robot, R), last)``)."""
    weight: float
    models: int = 1
    """Answer sets of the program (more than 1: what holds in all of them)."""

    @property
    def uniform(self) -> bool:
        """The knowledge base does not say where the robot is."""
        return not self.believed

    @property
    def message(self) -> str | None:
        """What a user should be told about how the prior was made, or None."""
        parts = []
        if self.uniform:
            parts.append(
                f"the knowledge base does not say where the robot is: each of the {len(self.rooms)} "
                f"{'regions' if OUTSIDE in self.rooms else 'rooms'} gets 1/{len(self.rooms)}"
            )
        if self.models > 1:
            parts.append(
                f"the knowledge base has {self.models} answer sets; the robot's room is what holds in all of them "
                "(cautious consequences)"
            )
        return "; ".join(parts) or None


@dataclass(frozen=True)
class DomainRobotPrior:
    """A domain's robot prior with what is shown beside it: the cells of each region on the
    domain's map, the step it is read at, and what a user should be warned about."""

    prior: RobotPrior
    cells: dict[str, int] | None
    """Region -> free cells of the domain's map (:data:`OUTSIDE` for those in no room); None
    when the domain references no map."""
    step: int
    """The answer set's step the prior is read at (its last)."""
    warnings: tuple[str, ...] = ()
    """clingo's warnings and :attr:`RobotPrior.message`, in that order."""

    def as_json(self) -> dict[str, Any]:
        """The record as plain JSON data (the stable interface for scripts)."""
        return {
            "rooms": list(self.prior.rooms),
            "prior": self.prior.prior,
            "robot_in": list(self.prior.believed),
            "weight": self.prior.weight,
            "uniform": self.prior.uniform,
            "cells": self.cells,
            "answer_sets": self.prior.models,
        }


@dataclass(frozen=True, eq=False)
class RobotStartBelief:
    """A start belief over a model's states from the robot's room prior (:func:`spread_over_states`)."""

    belief: np.ndarray
    """``belief[s]``: probability of state s; sums to 1."""
    prior: RobotPrior
    warnings: tuple[str, ...] = ()
    """clingo's warnings and :attr:`RobotPrior.message`, in that order."""


def robot_rooms(answer: AnswerSet, step: int | None = None) -> tuple[str, ...]:
    """The rooms R with ``holds(in(robot, R), step)`` (default: the last step), in room order."""
    located = {
        lit.args[1]
        for lit in answer.at(step)
        if lit.positive and lit.fluent == "in" and len(lit.args) == 2 and lit.args[0] == ROBOT
    }
    ordered = [room for room in answer.rooms if room in located]
    return (*ordered, *sorted(located - set(ordered)))


def check_weight(weight: float) -> float:
    """``weight`` itself when it is a weight w of the rule: in (0, 1] (at 0 the rooms the knowledge
    base names would get nothing). Raises :class:`InvalidValueError` otherwise."""
    if not 0.0 < weight <= 1.0:
        raise InvalidValueError(f"the weight w must be in (0, 1], got {weight:g}")
    return weight


def robot_room_prior(
    rooms: Sequence[str],
    believed: Sequence[str],
    *,
    weight: float = DEFAULT_WEIGHT,
    outside: bool = False,
    models: int = 1,
) -> RobotPrior:
    """The rule of the module docstring over ``rooms`` (plus :data:`OUTSIDE` when ``outside``).

    Raises :class:`InvalidValueError` for no rooms, a weight outside (0, 1] (:func:`check_weight`),
    or a believed room that is not one of ``rooms``.
    """
    if not rooms:
        raise InvalidValueError("no rooms: a prior over rooms needs at least one")
    check_weight(weight)
    unknown = [room for room in believed if room not in rooms]
    if unknown:
        raise InvalidValueError(
            f"the knowledge base puts the robot in {', '.join(unknown)}, which is not a room of: {', '.join(rooms)}"
        )
    regions = (*rooms, OUTSIDE) if outside else tuple(rooms)
    others = [room for room in regions if room not in believed]
    if not believed or not others:
        prior = {room: 1.0 / len(regions) for room in regions}
    else:
        prior = {room: weight / len(believed) if room in believed else (1.0 - weight) / len(others) for room in regions}
    return RobotPrior(regions, prior, tuple(believed), weight, models)


def robot_prior_from_answer(answer: AnswerSet, *, weight: float = DEFAULT_WEIGHT, outside: bool = False) -> RobotPrior:
    """:func:`robot_room_prior` over the answer set's rooms, for the rooms it puts the robot in."""
    return robot_room_prior(answer.rooms, robot_rooms(answer), weight=weight, outside=outside, models=answer.models)


def spread_over_states(prior: RobotPrior, room_states: Mapping[str, np.ndarray], n_states: int) -> np.ndarray:
    """The start belief: each room's probability spread uniformly over its states.

    ``room_states`` maps every room of the map to its state indices (disjoint); the states in no
    room are :data:`OUTSIDE`. Raises :class:`InvalidValueError` when a room of the prior has no
    states, or when the map has states in no room that the prior has no share for (or the other way
    round).
    """
    belief = np.zeros(n_states)
    covered = np.zeros(n_states, dtype=bool)
    for states in room_states.values():
        covered[states] = True
    outside = np.flatnonzero(~covered)
    for room in prior.rooms:
        states = outside if room == OUTSIDE else room_states.get(room, np.zeros(0, dtype=np.int64))
        if len(states) == 0:
            where = "no free cell in no room" if room == OUTSIDE else f"no cells for room {room!r}"
            raise InvalidValueError(f"the map has {where}, but the robot's prior gives it {prior.prior[room]:.3g}")
        belief[states] = prior.prior[room] / len(states)
    if len(outside) and OUTSIDE not in prior.rooms:
        raise InvalidValueError(f"{len(outside)} states are in no room, but the robot's prior has no share for them")
    extra = [room for room in room_states if room not in prior.prior]
    if extra:
        raise InvalidValueError(f"the map's rooms {', '.join(extra)} are not rooms of the knowledge base")
    return belief
