"""Grounding and solving a domain's knowledge base with clingo: the only module that imports clingo.

The program is ``kb/axioms.lp`` + the domain's own ``.lp`` files + any extra files, and the domain's
facts. Facts reach clingo as symbols: each kind of fact is a parametrised program part
(``#program is_fact(o, c). is(o, c).``) grounded with :func:`clingo.Function` arguments; nothing
from a domain file is ever pasted into program text.

Revision (multi-shot solving): every (object, room, step) has an external atom ``observed(O, R, I)``
with ``holds(in(O, R), I) :- observed(O, R, I).``; observing an object that the domain knows sets
its external true and solves again, without grounding again. An object the domain does not know
needs new ground rules, so the program is grounded afresh with it. ``benchmarks/bench_prior.py``
measures both.

The program's files are read and checked by :mod:`beliefloc.knowledge.files` before clingo sees
them (clingo loads private copies). The first grounding and search of a knowledge base run under a
budget of time and memory (:mod:`beliefloc.knowledge.budget`), in a child process; once a program
has been grounded within the budget in this process, knowledge bases that differ from it only in
where objects are known to be (the trials of ``search simulate``, a dynamic knowledge base's
revisions) and re-groundings after an observation run in the process itself, where the time budget
(and Ctrl-C) stop a search but not a grounding.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import clingo

from beliefloc.errors import InvalidValueError, KnowledgeBaseError
from beliefloc.knowledge.answer import AnswerSet, Literal, Timings
from beliefloc.knowledge.budget import run_budgeted, wait_solved
from beliefloc.knowledge.domain import ASP_NAME, Domain
from beliefloc.knowledge.files import NOT_LP, Program, Root, read_program
from beliefloc.knowledge.prior import DEFAULT_FLOOR, RoomPrior, room_prior
from beliefloc.knowledge.robot import ROBOT
from beliefloc.source import limits

_SHIPPED = Path(__file__).parent / "lp"
"""The axioms ship inside the package as links to the repository's hand-edited ``kb/`` files; a
wheel holds copies. Resolving the links names ``kb/...`` in messages when installed from a checkout."""
AXIOMS = (_SHIPPED / "axioms.lp").resolve()
ROBOT_AXIOMS = (_SHIPPED / "robot.lp").resolve()
"""Where the robot itself is (its dock, sightings, being carried); loaded with the axioms."""

_PARTS = """
#program room_fact(r). room(r).
#program class_fact(c). class(c).
#program subclass_fact(c, p). subclass(c, p).
#program is_fact(o, c). object(o). is(o, c).
#program in_fact(o, r). holds(in(o, r), 1).
#program on_fact(o, p). holds(on(o, p), 1).
#program accessible_fact(r). holds(accessible(r), 1).
#program inaccessible_fact(r). -holds(accessible(r), 1).
#program step_fact(i). step(i).
#program default_fact(d, c, r). default(d, c, r).
#program weak_fact(d, c). weak_exception(d, c).
#program possible_fact(d, c). possible_exception(d, c).
#program strong_fact(d, c). strong_exception(d, c).
#program robot_dock_fact(r). robot_dock(r).
#program robot_seen_fact(r). holds(in(robot, r), 1).
#program robot_carried_fact. robot_carried.
#program base.
% observations made by the robot, switched on through the API (multi-shot revision)
#external observed(O, R, I) : object(O), room(R), step(I).
holds(in(O, R), I) :- observed(O, R, I).
"""
_PARTS_NAME = "<beliefloc facts>"
_PROVEN: set[str] = set()
"""The shapes (:meth:`KnowledgeBase._shape`) of programs grounded and solved within the budget in
this process: another knowledge base of the same shape is grounded in the process itself."""
_PROVEN_KEPT = 256
_LOCATION = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+)(?:-\d+(?::\d+)?)?: (?P<text>.*)$", re.DOTALL)


@dataclass(frozen=True)
class Observation:
    """An object seen in a room at a step (default: the last step); ``cls`` for a new object."""

    obj: str
    room: str
    cls: str | None = None
    step: int | None = None

    @classmethod
    def parse(cls, text: str) -> Observation:
        """``OBJECT=ROOM`` (an object the domain knows) or ``OBJECT:CLASS=ROOM`` (a new object), at
        the last step; raises :class:`InvalidValueError` for any other text (the message says what
        to write; the caller names the text it was given)."""
        what, sep, room = text.partition("=")
        obj, _, class_ = what.partition(":")
        if not sep or not obj.strip() or not room.strip():
            raise InvalidValueError("write OBJECT=ROOM or OBJECT:CLASS=ROOM, e.g. book5=kitchen")
        names = [obj.strip(), room.strip(), *([class_.strip()] if class_.strip() else [])]
        for name in names:
            if not ASP_NAME.fullmatch(name):
                raise InvalidValueError(
                    f"{name!r} is not a name of the knowledge base: a lowercase letter, then lowercase letters, "
                    "digits and _ (at most 64)"
                )
        return cls(obj.strip(), room.strip(), class_.strip() or None)

    def describe(self, step: int) -> str:
        return f"holds(in({self.obj},{self.room}),{self.step or step})"


@dataclass(frozen=True)
class KnowledgeBaseSummary:
    """What checking a knowledge base found: it is consistent (else :meth:`KnowledgeBase.answer`
    raised), with its files, its answer set, clingo's warnings and timings."""

    domain: str
    """The domain's name."""
    files: tuple[Path, ...]
    answer: AnswerSet
    warnings: tuple[str, ...] = ()

    def as_json(self) -> dict[str, Any]:
        """The summary as plain JSON data (the stable interface for scripts): counts, not lists."""
        answer = self.answer
        return {
            "domain": self.domain,
            "files": [str(f) for f in self.files],
            "consistent": True,
            "answer_sets": answer.models,
            "rooms": len(answer.rooms),
            "classes": len(answer.classes),
            "objects": len(answer.members),
            "located": len(answer.located()),
            "ground_seconds": answer.timings.ground,
            "solve_seconds": answer.timings.solve,
            "warnings": list(self.warnings),
        }


def _fn(name: str, *args: clingo.Symbol) -> clingo.Symbol:
    return clingo.Function(name, list(args))


def _const(name: str) -> clingo.Symbol:
    return clingo.Function(name)


class KnowledgeBase:
    """A domain's knowledge base, grounded once and solved again after each observation.

    ``warnings`` holds clingo's warnings (each once); ``last_changed`` the facts added last.
    """

    def __init__(
        self,
        domain: Domain,
        kb_files: Sequence[Path] = (),
        observations: Iterable[Observation] = (),
        *,
        use_defaults: bool = True,
    ) -> None:
        self.domain = domain
        self.use_defaults = use_defaults
        """False: leave out the domain file's ``defaults:`` (defaults written in .lp files stay)."""
        roots = [Root(AXIOMS, None), Root(ROBOT_AXIOMS, None)]
        folder = domain.folder
        owner = f"the domain file {domain.path}" if domain.path is not None else "the working folder"
        roots += [Root(path, folder, owner, contains_self=True) for path in domain.kb_files()]
        roots += [Root(path, path.parent, f"the file {path}") for path in kb_files]
        seen: set[Path] = set()
        self.files: list[Path] = []
        for root in roots:
            key = root.path.resolve()
            if key not in seen:
                seen.add(key)
                self.files.append(root.path)
        self.program: Program = read_program(roots, allow_outside=domain.allow_outside)
        """The files clingo loads, read and checked (:func:`~beliefloc.knowledge.files.read_program`)."""
        self.warnings: list[str] = []
        self._errors: list[str] = []
        self.last_changed: list[str] = []
        self.timings = Timings()
        self._new_objects: dict[str, str] = {}
        self._observations: list[Observation] = []
        self._answer: AnswerSet | None = None
        self._control: clingo.Control | None = None
        self._first_answer()
        for observation in observations:
            self.observe(observation)

    # grounding
    def _log(self, code: clingo.MessageCode, message: str) -> None:
        text = self.program.shown(message.strip())
        if code == clingo.MessageCode.RuntimeError:
            self._errors.append(text)
        elif text not in self.warnings:
            self.warnings.append(text)

    @property
    def label(self) -> str:
        """The knowledge base in messages: the domain file (or name) and the program's own files."""
        where = str(self.domain.path) if self.domain.path is not None else f"domain {self.domain.name!r}"
        own = [str(path) for path in self.files if path not in (AXIOMS, ROBOT_AXIOMS)]
        return f"{where} (with {', '.join(own)})" if own else where

    def _first_answer(self) -> None:
        """Ground and solve for the first time: under the budget in a child process, unless a
        program of the same shape was grounded within it already (:data:`_PROVEN`)."""
        key = self._shape()
        if key in _PROVEN:
            self._control = self._ground()
            self._answer = self._solve()
            return
        found = run_budgeted(self._answer_texts, self.label)
        for message in found["warnings"]:
            if message not in self.warnings:
                self.warnings.append(message)
        self.timings = Timings(found["ground"], found["solve"])
        rooms = list(self.domain.rooms)
        self._answer = _to_answer(found["atoms"], rooms, self.domain.steps, found["models"], self.timings)
        if len(_PROVEN) >= _PROVEN_KEPT:
            _PROVEN.clear()
        _PROVEN.add(key)

    def _answer_texts(self) -> dict[str, Any]:
        """Ground and solve here (in the budget's child process): the answer as JSON data."""
        self._control = self._ground()
        atoms, models = self._search()
        return {
            "atoms": atoms,
            "models": models,
            "warnings": self.warnings,
            "ground": self.timings.ground,
            "solve": self.timings.solve,
        }

    def _shape(self) -> str:
        """What decides how large the grounding is: the program's files and the domain's facts, but
        for where objects are known to be (which the trials of a simulation vary)."""
        d = self.domain
        facts = {
            "rooms": {name: room.accessible for name, room in d.rooms.items()},
            "classes": d.classes,
            "objects": {name: obj.class_ for name, obj in d.objects.items()},
            "defaults": {name: default.model_dump(by_alias=True) for name, default in d.defaults.items()}
            if self.use_defaults
            else {},
            "robot": d.robot.model_dump() if d.robot is not None else None,
            "steps": d.steps,
        }
        text = json.dumps(facts, sort_keys=True) + self.program.digest
        return hashlib.sha256(text.encode()).hexdigest()

    def _control_ready(self) -> clingo.Control:
        """The grounded program in this process (grounded now when the first answer came from the
        budget's child process)."""
        if self._control is None:
            self._control = self._ground()
        return self._control

    def _ground(self) -> clingo.Control:
        self._errors = []
        ctl = clingo.Control(["--models=0", "--enum-mode=cautious"], logger=self._log, message_limit=100)
        for loaded, path in zip(self.program.top, self.files, strict=True):
            try:
                ctl.load(str(loaded))
            except RuntimeError as exc:
                raise KnowledgeBaseError(self._error_text(f"{path}: cannot be parsed", exc)) from None
        try:
            ctl.add("base", [], _PARTS)
        except RuntimeError as exc:  # pragma: no cover - the fixed program text is tested
            raise KnowledgeBaseError(self._error_text("internal program", exc)) from None
        start = time.perf_counter()
        try:
            ctl.ground(self._fact_parts())
        except RuntimeError as exc:
            raise KnowledgeBaseError(self._error_text("grounding failed", exc)) from None
        self.timings = Timings(ground=time.perf_counter() - start)
        return ctl

    def _error_text(self, fallback: str, exc: BaseException | None = None) -> str:
        """clingo's first error as ``file:line:col: message`` (the files' own names, not the copies')."""
        for text in [*self._errors, *([str(exc)] if exc is not None else [])]:
            match = _LOCATION.match(self.program.shown(text.strip()))
            if match:
                body = match["text"].removeprefix("error: ").strip()
                file = match["file"]
                hint = "" if file.endswith(".lp") or file.startswith("<") else f"; {NOT_LP.format(file)}"
                return f"{file}:{match['line']}:{match['col']}: {body}{hint}"
        return self.program.shown(self._errors[0]) if self._errors else fallback

    def _fact_parts(self) -> list[tuple[str, Sequence[clingo.Symbol]]]:
        d = self.domain
        parts: list[tuple[str, Sequence[clingo.Symbol]]] = [("base", [])]
        parts += [("step_fact", [clingo.Number(i)]) for i in range(1, d.steps + 1)]
        for name, room in d.rooms.items():
            parts.append(("room_fact", [_const(name)]))
            parts.append(("accessible_fact" if room.accessible else "inaccessible_fact", [_const(name)]))
        for cls, parent in d.classes.items():
            parts.append(("class_fact", [_const(cls)]))
            if parent is not None:
                parts.append(("subclass_fact", [_const(cls), _const(parent)]))
        objects = {**{o: spec.class_ for o, spec in d.objects.items()}, **self._new_objects}
        for obj, cls in objects.items():
            parts.append(("is_fact", [_const(obj), _const(cls)]))
        for obj, spec in d.objects.items():
            if spec.room is not None:
                parts.append(("in_fact", [_const(obj), _const(spec.room)]))
            if spec.on is not None:
                parts.append(("on_fact", [_const(obj), _const(spec.on)]))
        for name, default in (d.defaults if self.use_defaults else {}).items():
            parts.append(("default_fact", [_const(name), _const(default.class_), _const(default.room)]))
            for kind, classes in (
                ("weak_fact", default.weak_exceptions),
                ("possible_fact", default.possible_exceptions),
                ("strong_fact", default.strong_exceptions),
            ):
                parts += [(kind, [_const(name), _const(cls)]) for cls in classes]
        robot = d.robot
        if robot is not None:
            if robot.dock is not None:
                parts.append(("robot_dock_fact", [_const(robot.dock)]))
            if robot.last_seen is not None:
                parts.append(("robot_seen_fact", [_const(robot.last_seen)]))
            if robot.carried:
                parts.append(("robot_carried_fact", []))
        return parts

    # solving
    def answer(self) -> AnswerSet:
        """The answer set (or the cautious consequences of several); raises when there is none."""
        if self._answer is None:
            self._answer = self._solve()
        return self._answer

    def _solve(self) -> AnswerSet:
        atoms, models = self._search()
        return _to_answer(atoms, list(self.domain.rooms), self.domain.steps, models, self.timings)

    def _search(self) -> tuple[list[str], int]:
        """Solve the grounded program (cautious consequences): the shown atoms as text, and how many
        models were found; raises when there is none. Waited for in slices, so that Ctrl-C and the
        time budget (:data:`~beliefloc.source.limits.GROUNDING_SECONDS`) stop it."""
        control = self._control_ready()
        start = time.perf_counter()
        found: dict[str, Any] = {"models": 0, "atoms": []}

        def on_model(model: clingo.Model) -> None:  # cautious mode: each model a smaller intersection
            found["models"] += 1
            found["atoms"] = [str(symbol) for symbol in model.symbols(shown=True)]

        deadline = time.monotonic() + limits.GROUNDING_SECONDS.value
        with control.solve(on_model=on_model, async_=True) as handle:
            wait_solved(handle, deadline, self.label)
            handle.get()
        self.timings = Timings(self.timings.ground, time.perf_counter() - start)
        if found["models"] == 0:
            what = "; ".join(self.last_changed) if self.last_changed else "the domain's facts and the axioms"
            raise KnowledgeBaseError(
                f"the knowledge base is inconsistent (it has no answer set); the facts that last changed it: {what}"
            )
        return found["atoms"], found["models"]

    # revision
    def observe(self, observation: Observation) -> bool:
        """Add an observed fact and re-solve; returns whether it was new.

        The same observation twice changes nothing. An observation that makes the knowledge base
        inconsistent is taken back and raises :class:`KnowledgeBaseError` naming it.
        """
        step = observation.step or self.domain.steps
        if not 1 <= step <= self.domain.steps:
            raise KnowledgeBaseError(f"step {step} is outside the domain's steps 1..{self.domain.steps}")
        if observation.room not in self.domain.rooms:
            raise KnowledgeBaseError(
                f"unknown room {observation.room!r}; expected one of: {', '.join(self.domain.rooms)}"
            )
        key = Observation(observation.obj, observation.room, None, step)
        if key in self._observations:
            return False
        control = self._control_ready()
        known = control.symbolic_atoms[self._observed(key)] is not None  # also objects from .lp files
        if not known:
            if observation.cls is None:
                raise KnowledgeBaseError(f"unknown object {observation.obj!r}: give its class to add it")
            if observation.cls not in self.domain.classes:
                raise KnowledgeBaseError(f"unknown class {observation.cls!r} for the new object {observation.obj!r}")
            clash = self._name_clash(observation.obj)
            if clash:
                raise KnowledgeBaseError(f"the new object {observation.obj!r} {clash}; give it another name")
        previous = (self._control, dict(self._new_objects), self.timings)
        self._observations.append(key)
        self.last_changed = [key.describe(step)]
        if not known:
            assert observation.cls is not None
            self._new_objects[observation.obj] = observation.cls
            self._control = self._ground()
            for earlier in self._observations:
                self._switch(earlier, True)
        else:
            self._switch(key, True)
        try:
            self._answer = self._solve()
        except KnowledgeBaseError:
            self._observations.pop()
            self._control, self._new_objects, self.timings = previous
            self._switch(key, False)
            self._answer = None
            raise
        return True

    def _name_clash(self, name: str) -> str | None:
        """Why a new object may not be called ``name`` (None: it may)."""
        d = self.domain
        if name == ROBOT:
            return "is the robot itself (kb/robot.lp)"
        if name in d.rooms:
            return "is a room"
        if name in d.classes:
            return "is a class"
        return None

    @staticmethod
    def _observed(observation: Observation) -> clingo.Symbol:
        step = clingo.Number(observation.step or 1)
        return _fn("observed", _const(observation.obj), _const(observation.room), step)

    def _switch(self, observation: Observation, value: bool) -> None:
        self._control_ready().assign_external(self._observed(observation), value)

    @property
    def observations(self) -> tuple[Observation, ...]:
        return tuple(self._observations)

    def prior(self, target: str, *, floor: float = DEFAULT_FLOOR) -> RoomPrior:
        """Eq. 2-5 from the current answer set, for ``target`` (a class)."""
        return room_prior_from_answer(self.answer(), target, floor=floor)

    def summary(self) -> KnowledgeBaseSummary:
        """Solve (raising when the knowledge base is inconsistent) and say what was found."""
        answer = self.answer()
        return KnowledgeBaseSummary(self.domain.name, tuple(self.files), answer, tuple(self.warnings))


def room_prior_from_answer(answer: AnswerSet, target: str, *, floor: float = DEFAULT_FLOOR) -> RoomPrior:
    """The room prior for ``target`` from the objects located at the answer set's last step."""
    if target not in answer.classes:
        shown = ", ".join(sorted(answer.classes))
        raise KnowledgeBaseError(f"unknown target class {target!r}; expected one of: {shown}")
    n = len(answer.rooms)
    if n and not (floor > 0.0 and floor * n < 1.0):  # NaN too
        raise InvalidValueError(f"the floor must be above 0 and below 1/{n} (1 / number of rooms), got {floor:g}")
    try:
        return room_prior(answer.rooms, answer.parents, answer.counts(), target, floor=floor, models=answer.models)
    except ValueError as exc:
        raise KnowledgeBaseError(str(exc)) from None


def domain_prior(
    domain: Domain,
    target: str,
    *,
    observations: Iterable[Observation] = (),
    kb_files: Sequence[Path] = (),
    floor: float = DEFAULT_FLOOR,
    use_defaults: bool = True,
) -> RoomPrior:
    """The prior over rooms for ``target``: a validated domain (+ observed facts) -> Eq. 5."""
    kb = KnowledgeBase(domain, kb_files, observations, use_defaults=use_defaults)
    return kb.prior(target, floor=floor)


_HOLDS = re.compile(r"^(-?)holds\(([a-z_][A-Za-z0-9_']*)(?:\((.*)\))?,(-?\d+)\)$")
_ATOM = re.compile(r"^([a-z_][A-Za-z0-9_']*)\((.*)\)$")


def _to_answer(
    symbols: Sequence[str], room_order: list[str], last_step: int, models: int, timings: Timings
) -> AnswerSet:
    """The shown atoms, parsed from their text: one call into clingo per atom instead of one per part
    (the 1,200 atoms of domains/home.yaml took 14 ms through Symbol.name/arguments, 3 ms so)."""
    literals: list[Literal] = []
    abnormal: list[str] = []
    rooms: list[str] = []
    classes: list[str] = []
    parents: dict[str, str] = {}
    members: list[tuple[str, str]] = []
    for text in symbols:
        holds = _HOLDS.match(text)
        if holds is not None:
            sign, fluent, args, step = holds.groups()
            literals.append(Literal(int(step), fluent, tuple(args.split(",")) if args else (), not sign))
            continue
        atom = _ATOM.match(text)
        if atom is None:
            continue
        name, inner = atom.groups()
        if name == "ab":
            abnormal.append(text)
            continue
        args = inner.split(",")
        if name == "room" and len(args) == 1:
            rooms.append(args[0])
        elif name == "class" and len(args) == 1:
            classes.append(args[0])
        elif name == "subclass" and len(args) == 2:
            child, parent = args
            if child in parents and parents[child] != parent:
                raise KnowledgeBaseError(
                    f"class {child!r} has two parents ({parents[child]}, {parent}); the class hierarchy must be a tree"
                )
            parents[child] = parent
        elif name == "is" and len(args) == 2:
            members.append((args[0], args[1]))
    order = {room: index for index, room in enumerate(room_order)}
    return AnswerSet(
        literals=tuple(sorted(literals)),
        abnormal=tuple(sorted(abnormal)),
        rooms=tuple(sorted(rooms, key=lambda r: (order.get(r, len(order)), r))),
        classes=tuple(sorted(classes)),
        parents=parents,
        members=tuple(sorted(members)),
        last_step=last_step,
        models=models,
        timings=timings,
    )
