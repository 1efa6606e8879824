"""An answer set as plain Python data: what the robot believes, per step. No clingo here."""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any

from beliefloc.errors import InvalidValueError


@dataclass(frozen=True, order=True)
class Literal:
    """``holds(F, I)`` (``positive``) or ``-holds(F, I)`` for a fluent ``F = name(args...)``."""

    step: int
    fluent: str
    args: tuple[str, ...]
    positive: bool = True

    def __str__(self) -> str:
        sign = "" if self.positive else "-"
        return f"{sign}holds({self.fluent}({','.join(self.args)}),{self.step})"


@dataclass(frozen=True)
class Timings:
    """Seconds spent in clingo: grounding and solving, measured apart."""

    ground: float = 0.0
    solve: float = 0.0


@dataclass(frozen=True)
class AnswerSet:
    """The shown atoms of the answer set, or of the intersection of all answer sets.

    ``models`` is 1 when the program has exactly one answer set (the paper's assumption); when it
    is 2 or more, the atoms are the *cautious consequences* (those true in every answer set), so
    that nothing believed depends on an arbitrary choice between answer sets.
    """

    literals: tuple[Literal, ...]
    abnormal: tuple[str, ...]
    """``ab(...)`` atoms: which objects a default does not apply to."""
    rooms: tuple[str, ...]
    classes: tuple[str, ...]
    parents: dict[str, str]
    """``subclass(C, P)``: class -> parent."""
    members: tuple[tuple[str, str], ...]
    """``is(O, C)``: (object, primary class)."""
    last_step: int
    models: int = 1
    timings: Timings = field(default_factory=Timings)

    def check_step(self, step: int | None = None) -> int:
        """``step`` (default: the last step) when it is one of the answer set's steps 1..last;
        raises :class:`InvalidValueError` otherwise (the message gives the range; the caller names
        the step it was given)."""
        wanted = self.last_step if step is None else step
        if not 1 <= wanted <= self.last_step:
            raise InvalidValueError(f"the domain has steps 1..{self.last_step}")
        return wanted

    def as_json(self, step: int | None = None) -> dict[str, Any]:
        """The beliefs at ``step`` (default: the last; checked by :meth:`check_step`) as plain JSON
        data: the ``holds`` literals grouped by fluent, and the ``ab`` atoms."""
        shown = self.check_step(step)
        return {
            "step": shown,
            "answer_sets": self.models,
            "holds": {group: [str(lit) for lit in lits] for group, lits in self.grouped(shown).items()},
            "ab": list(self.abnormal),
        }

    def at(self, step: int | None = None) -> list[Literal]:
        """The literals at ``step`` (default: the last step), sorted."""
        wanted = self.last_step if step is None else step
        return sorted(lit for lit in self.literals if lit.step == wanted)

    def grouped(self, step: int | None = None) -> dict[str, list[Literal]]:
        """Literals at ``step`` grouped by fluent: ``in``, ``exists``, ... and ``-in``, ``-exists``."""
        groups: dict[str, list[Literal]] = defaultdict(list)
        for lit in self.at(step):
            groups[lit.fluent if lit.positive else f"-{lit.fluent}"].append(lit)
        return dict(sorted(groups.items(), key=lambda kv: (kv[0].startswith("-"), kv[0])))

    def located(self, step: int | None = None) -> dict[str, str]:
        """Object -> room for every ``holds(in(O, R), step)`` of an object (``is(O, C)``); the robot's
        own room (``kb/robot.lp``) is not an object's: see :func:`beliefloc.knowledge.robot.robot_rooms`."""
        objects = {obj for obj, _ in self.members}
        return {
            lit.args[0]: lit.args[1]
            for lit in self.at(step)
            if lit.positive and lit.fluent == "in" and lit.args[0] in objects
        }

    def counts(self, step: int | None = None) -> dict[str, dict[str, int]]:
        """Room -> primary class -> number of objects of that class in the room (the paper's a_{k,n})."""
        located = self.located(step)
        counts: dict[str, dict[str, int]] = {room: {} for room in self.rooms}
        for obj, cls in self.members:
            room = located.get(obj)
            if room is not None:
                per_room = counts.setdefault(room, {})
                per_room[cls] = per_room.get(cls, 0) + 1
        return counts
