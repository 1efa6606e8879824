"""Simulated worlds for object-search trials (Zhang, Sridharan & Wyatt 2015, Sec. IV-A). Pure and seeded:
no clingo, no I/O; randomness only through passed Generators.

A trial has a *ground truth* and what the *robot knows* of it:

* **Ground truth** (:func:`sample_world`): every object of the domain is in a room and on a cell.
  An object the domain file places (``room:``) is there; an object standing ``on`` another is in
  that one's room. Any other object is in its *typical room* -- where the domain's defaults put it,
  as the knowledge base concludes at step 1 (:func:`~beliefloc.object_search.experiment.typical_rooms`
  computes it with clingo, once per domain) -- with probability ``p_typical``
  (:data:`P_TYPICAL` = 0.8), and otherwise in a room drawn uniformly among the rooms it may be in:
  those the robot can enter, less the rooms a strong exception of a domain default rules out
  (:func:`forbidden_rooms`; a known fact there would make the knowledge base inconsistent). So an
  object with a default is in its typical room with probability ``p + (1 - p) / rooms``. Each
  object's cell is drawn uniformly in its room.
* **The target** is one object of the domain: one of the instances of the target class (or of any
  class), drawn uniformly among those whose true room the robot can enter -- a target the robot
  could never reach would measure the domain, not the search. The detector responds to that
  instance only (the paper: "the robot has to find one instance of the target"). An *absent*
  target was drawn the same way and then taken out of the world.
* **The robot's knowledge** (:func:`sample_known`, :func:`robot_domain`): the true rooms of a
  random fraction ``knowledge`` of the other objects (``round(knowledge x n)`` of them, drawn
  uniformly; the paper's "% of domain knowledge"); it never knows the target's. The robot's domain
  is the domain file with only those rooms (``on`` facts are dropped: the robot knows rooms, nothing
  else); with or without defaults is the knowledge base's ``use_defaults``.

Paired trials (Sec. IV-A: "the initial cell-level location of the robot, the target(s) ... are
fixed, and the robot has the same amount of domain knowledge") share the trial's world and
knowledge, and each arm gets fresh generators of the same streams (:func:`trial_rng`).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from beliefloc.errors import UsageError
from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.world import SearchSpace

P_TYPICAL = 0.8
"""Probability that an object with a default is in the room the default says (our choice)."""


class Stream(enum.IntEnum):
    """The independent random streams of one trial (:func:`trial_rng`)."""

    WORLD = 0
    """Absent or not, where every object is, which instance is the target."""
    KNOWLEDGE = 1
    """Which objects' rooms the robot knows."""
    TARGET_DETECTIONS = 2
    BETA_SAMPLES = 3
    OBJECT_DETECTIONS = 4


def trial_rng(seed: int, index: int, stream: Stream) -> np.random.Generator:
    """A fresh generator for one stream of trial ``index`` of a run seeded ``seed``: every call gives
    the same numbers, so every arm of a paired trial sees the same noise."""
    return np.random.default_rng(np.random.SeedSequence([seed, index, int(stream)]))


def ancestors(domain: Domain, cls: str) -> list[str]:
    """``cls`` and its ancestors up to the root (the hierarchy is a validated tree)."""
    chain = [cls]
    parent = domain.classes.get(cls)
    while parent is not None:
        chain.append(parent)
        parent = domain.classes.get(parent)
    return chain


def instances_of(domain: Domain, cls: str) -> list[str]:
    """The objects of class ``cls`` or of a class below it, in the domain's order."""
    return [name for name, spec in domain.objects.items() if cls in ancestors(domain, spec.class_)]


def forbidden_rooms(domain: Domain) -> dict[str, frozenset[str]]:
    """Rooms each object is known NOT to be in: the strong exceptions of the domain file's defaults,
    ``-holds(in(X, R), 1) :- strong_exception(D, C), default(D, _, R), instance(X, C)`` (kb/axioms.lp).
    Defaults written in ``.lp`` files are not read here."""
    out: dict[str, set[str]] = {}
    for default in domain.defaults.values():
        for cls in default.strong_exceptions:
            for name in instances_of(domain, cls):
                out.setdefault(name, set()).add(default.room)
    return {name: frozenset(rooms) for name, rooms in out.items()}


@dataclass(frozen=True)
class World:
    """The ground truth of one trial."""

    rooms: Mapping[str, str]
    """Object -> the room it is in (every object of the domain but an absent target)."""
    cells: Mapping[str, int]
    """Object -> the cell it stands on (the same objects)."""
    target: str
    """The object searched for (an instance of ``target_class``)."""
    target_class: str
    present: bool

    @property
    def target_cell(self) -> int | None:
        return self.cells.get(self.target) if self.present else None

    @property
    def target_room(self) -> str | None:
        return self.rooms.get(self.target) if self.present else None


def place_objects(
    domain: Domain,
    space: SearchSpace,
    typical: Mapping[str, str],
    rng: np.random.Generator,
    *,
    p_typical: float = P_TYPICAL,
) -> tuple[dict[str, str], dict[str, int]]:
    """Every object's room and cell (see the module docstring); ``typical``: object -> typical room."""
    if not 0.0 <= p_typical <= 1.0:
        raise ValueError(f"p_typical must be in [0, 1], got {p_typical}")
    enterable = [room for room in domain.rooms if domain.rooms[room].accessible]
    forbidden = forbidden_rooms(domain)
    rooms: dict[str, str] = {}
    for name, spec in domain.objects.items():
        if spec.room is not None:
            rooms[name] = spec.room
        elif spec.on is None:
            rooms[name] = _draw_room(name, typical, enterable, forbidden, rng, p_typical)
    for name, spec in domain.objects.items():  # an object on another one is in that one's room
        if name not in rooms:
            base, seen = spec.on, {name}
            while base is not None and base not in rooms and base not in seen:
                seen.add(base)
                base = domain.objects[base].on
            rooms[name] = (
                rooms[base] if base is not None and base in rooms else _draw_room(name, {}, enterable, {}, rng, 0.0)
            )
    cells: dict[str, int] = {}
    for name in domain.objects:
        in_room = space.cells_of(space.rooms.index(rooms[name]))
        cells[name] = int(in_room[rng.integers(len(in_room))])
    return {name: rooms[name] for name in domain.objects}, cells


def _draw_room(
    name: str,
    typical: Mapping[str, str],
    enterable: list[str],
    forbidden: Mapping[str, frozenset[str]],
    rng: np.random.Generator,
    p_typical: float,
) -> str:
    usual = typical.get(name)
    if usual is not None and rng.random() < p_typical:
        return usual
    allowed = [room for room in enterable if room not in forbidden.get(name, frozenset())] or enterable
    return allowed[int(rng.integers(len(allowed)))]


def sample_world(
    domain: Domain,
    space: SearchSpace,
    typical: Mapping[str, str],
    rng: np.random.Generator,
    *,
    target_class: str | None = None,
    absent: bool = False,
    p_typical: float = P_TYPICAL,
) -> World:
    """One ground truth (see the module docstring). ``target_class`` None: any object may be the target.

    Raises :class:`UsageError` when no object of the target class is in a room the robot can enter."""
    if target_class is not None and target_class not in domain.classes:
        raise UsageError(f"unknown target class {target_class!r}; expected one of: {', '.join(sorted(domain.classes))}")
    enterable = {room for room in domain.rooms if domain.rooms[room].accessible}
    rooms, cells = place_objects(domain, space, typical, rng, p_typical=p_typical)
    pool = list(domain.objects) if target_class is None else instances_of(domain, target_class)
    candidates = [name for name in pool if rooms[name] in enterable]
    if not candidates:
        what = "objects" if target_class is None else f"objects of class {target_class!r}"
        raise UsageError(
            f"domain {domain.name!r} has no {what} the robot could find (none, or all in rooms marked "
            "'accessible: false'): add one under 'objects:' (without 'room:' to leave its place to chance)"
        )
    target = candidates[int(rng.integers(len(candidates)))]
    chosen_class = target_class if target_class is not None else domain.objects[target].class_
    if absent:
        rooms = {k: v for k, v in rooms.items() if k != target}
        cells = {k: v for k, v in cells.items() if k != target}
    return World(rooms, cells, target, chosen_class, not absent)


def sample_known(domain: Domain, world: World, fraction: float, rng: np.random.Generator) -> frozenset[str]:
    """The objects whose true room the robot knows: ``round(fraction x n)`` of the ``n`` objects other
    than the target, drawn uniformly."""
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"the fraction of known objects must be in [0, 1], got {fraction}")
    others = [name for name in domain.objects if name != world.target]
    count = round(fraction * len(others))
    chosen = rng.choice(len(others), size=count, replace=False) if count else np.zeros(0, dtype=int)
    return frozenset(others[int(i)] for i in chosen)


def robot_domain(domain: Domain, world: World, known: frozenset[str]) -> Domain:
    """The domain as the robot knows it: every object, with its true room only when it is ``known``,
    and no ``on`` facts (a validated domain copied, not re-read)."""
    objects = {
        name: spec.model_copy(update={"room": world.rooms[name] if name in known else None, "on": None})
        for name, spec in domain.objects.items()
    }
    return domain.model_copy(update={"objects": objects})


def unknown_objects(domain: Domain, world: World, known: frozenset[str]) -> list[str]:
    """The objects of the world the robot may learn about during a search (dynamic KB): those whose
    room it does not know, but the target."""
    return [name for name in domain.objects if name in world.rooms and name not in known and name != world.target]
