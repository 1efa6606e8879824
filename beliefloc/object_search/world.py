"""The simulated world of object search (Zhang, Sridharan & Wyatt 2015, Sec. IV-A): where every object
is, and the detector that answers the robot's views. Pure numpy and seeded: randomness only through
passed Generators, no I/O; clingo only in :func:`typical_rooms`, which asks the knowledge base once
per domain.

The robot's model (:class:`~beliefloc.object_search.space.SearchSpace`) may differ from this world:
the world's detector may be noisier than the one the robot assumes (DESIGN.md, "Roles that stay
apart").

* **Ground truth** (:func:`sample_world`, :class:`World`): every object of the domain is in a room
  and on a cell. An object the domain file places (``room:``) is there; an object standing ``on``
  another is in that one's room. Any other object is in its *typical room* -- where the domain's
  defaults put it, as the knowledge base concludes at step 1 (:func:`typical_rooms` computes it
  with clingo, once per domain) -- with probability ``p_typical`` (:data:`P_TYPICAL` = 0.8), and
  otherwise in a room drawn uniformly among the rooms it may be in: those the robot can enter, less
  the rooms a strong exception of a domain default rules out (:func:`forbidden_rooms`; a known fact
  there would make the knowledge base inconsistent). So an object with a default is in its typical
  room with probability ``p + (1 - p) / rooms``. Each object's cell is drawn uniformly in its room.
* **The target** is one object of the domain: one of the instances of the target class (or of any
  class), drawn uniformly among those whose true room the robot can enter -- a target the robot
  could never reach would measure the domain, not the search. The detector responds to that
  instance only (the paper: "the robot has to find one instance of the target"). An *absent*
  target was drawn the same way and then taken out of the world.
* **Detections**: :class:`SimulatedTarget` and :class:`SimulatedObjects` know where the target and
  the other objects are (or that the target is absent) and answer a view with present/absent at
  the detector's rates.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from beliefloc.errors import DomainError, InvalidValueError
from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.posterior import Detector
from beliefloc.object_search.scene import (
    Appearance,
    SceneModel,
    SceneRates,
    SceneTrace,
    sample_image,
    simulate_scene,
)
from beliefloc.object_search.settings import check_fraction
from beliefloc.object_search.space import SearchSpace

P_TYPICAL = 0.8
"""Probability that an object with a default is in the room the default says (our choice)."""


@dataclass
class SimulatedTarget:
    """The world's side: where the target is (``None``: absent) and a seeded detector."""

    cell: int | None
    detector: Detector
    rng: np.random.Generator

    @classmethod
    def at_random(
        cls, space: SearchSpace, rng: np.random.Generator, detector_rng: np.random.Generator
    ) -> SimulatedTarget:
        """The target in a cell drawn uniformly over the cells of the rooms the robot can enter."""
        candidates = np.flatnonzero(space.reachable)
        return cls(int(candidates[rng.integers(len(candidates))]), space.detector, detector_rng)

    def detect(self, cells: np.ndarray) -> bool:
        """Analyse a view (the cells it covers, as indices or a boolean mask): True for ``present``."""
        seen = self.cell is not None and _covers(cells, self.cell)
        rate = self.detector.true_positive if seen else self.detector.false_positive
        return bool(self.rng.random() < rate)


@dataclass
class SceneTarget:
    """The world's side with a scene model: where the target is (``None``: absent), and, per view, an
    image of the view's ROIs -- the target's when it is in view, among distractors drawn from the
    *world's* objects in the view point's room (``room_looks``, axis: the space's rooms) -- processed
    by the robot's two policies for that room (``rates.outcomes``), each operator's report drawn from
    its confusion row (:func:`~beliefloc.object_search.scene.simulate_scene`)."""

    cell: int | None
    model: SceneModel
    rates: SceneRates
    room_of_view: np.ndarray
    room_looks: tuple[tuple[Appearance, ...], ...]
    rng: np.random.Generator
    look: Appearance | None = None
    """What the target truly looks like: its instance's class (a search for ``bedding`` finds a pillow);
    None: the appearance of the class searched for."""

    def analyse(self, view: int, cells: np.ndarray) -> SceneTrace:
        """Process the image of view ``view`` (covering ``cells``)."""
        seen = self.cell is not None and _covers(cells, self.cell)
        room = int(self.room_of_view[view])
        look = self.look if self.look is not None else self.model.look(self.rates.target_class)
        target = look if seen else None
        looks, where = sample_image(self.model, target, self.room_looks[room], self.rng)
        return simulate_scene(self.model, self.rates.outcomes[room], looks, where, self.rng)


def _covers(cells: np.ndarray, cell: int) -> bool:
    if cells.dtype == bool:
        return bool(cells[cell])
    return bool(np.any(cells == cell))


@dataclass
class SimulatedObjects:
    """The world's side for the other objects (Algorithm 1, lines 7-10): where each one stands and a
    seeded detector that looks for every one of them in each analysed view (the target's rates)."""

    names: tuple[str, ...]
    cells: np.ndarray
    """``cells[j]``: the cell object ``names[j]`` stands on (int, shape (objects,))."""
    detector: Detector
    rng: np.random.Generator

    def detect(self, cells: np.ndarray) -> np.ndarray:
        """One detection per object for the view covering ``cells`` (indices): True for ``present``.

        Draws one number per object every time, so the stream does not depend on what the robot
        does with the answers."""
        seen = np.isin(self.cells, cells)
        rate = np.where(seen, self.detector.true_positive, self.detector.false_positive)
        result: np.ndarray = self.rng.random(len(self.names)) < rate
        return result


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
    return [name for name, obj in domain.objects.items() if cls in ancestors(domain, obj.class_)]


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


def class_rooms(domain: Domain) -> dict[str, str]:
    """Every class's *home room*, the room a correlated world (:func:`place_objects` with
    ``correlation``) ties it to: the room of the nearest default up the class hierarchy that does not
    except the class (weak, possible or strong); for a class no default covers, the room where the
    domain file places most instances of the class (ties: the room listed first), or, when it places
    none, of its parent, and so on up; else the first room the robot can enter."""
    enterable = [room for room in domain.rooms if domain.rooms[room].accessible] or list(domain.rooms)
    homes: dict[str, str] = {}
    for cls in domain.classes:
        chain = ancestors(domain, cls)
        home = None
        for level in chain:
            for default in domain.defaults.values():
                excepted = {*default.weak_exceptions, *default.possible_exceptions, *default.strong_exceptions}
                if default.class_ == level and not excepted & set(chain):
                    home = default.room
                    break
            if home is not None:
                break
        if home is None:
            for level in chain:
                counts = {room: 0 for room in domain.rooms}
                for name in instances_of(domain, level):
                    placed = domain.objects[name].room
                    if placed is not None:
                        counts[placed] += 1
                top = max(counts.values())
                if top > 0:
                    home = next(room for room in domain.rooms if counts[room] == top)
                    break
        homes[cls] = home if home is not None and home in enterable else enterable[0]
    return homes


def place_objects(
    domain: Domain,
    space: SearchSpace,
    typical: Mapping[str, str],
    rng: np.random.Generator,
    *,
    p_typical: float = P_TYPICAL,
    correlation: float | None = None,
) -> tuple[dict[str, str], dict[str, int]]:
    """Every object's room and cell (see the module docstring); ``typical``: object -> typical room.

    ``correlation`` ρ (None: the placement above): a *correlated world*, the class-to-room ties of the
    paper's simulated domain (Sec. IV-A: rooms hold objects of related classes). Every object -- those
    the domain file places too: the file's rooms are then the robot's knowledge in a single search, not
    a trial's world -- is in its class's home room (:func:`class_rooms`) with probability ρ, else in
    one of the other rooms the robot can enter, drawn uniformly."""
    check_fraction("p_typical", p_typical)
    enterable = [room for room in domain.rooms if domain.rooms[room].accessible]
    forbidden = forbidden_rooms(domain)
    rooms: dict[str, str] = {}
    if correlation is not None:
        check_fraction("the correlation", correlation)
        homes = class_rooms(domain)
    for name, obj in domain.objects.items():
        if correlation is not None:
            if obj.on is None:
                home = homes[obj.class_]
                others = [room for room in enterable if room != home]
                tied = not others or rng.random() < correlation
                rooms[name] = home if tied else others[int(rng.integers(len(others)))]
        elif obj.room is not None:
            rooms[name] = obj.room
        elif obj.on is None:
            rooms[name] = _draw_room(name, typical, enterable, forbidden, rng, p_typical)
    for name, obj in domain.objects.items():  # an object on another one is in that one's room
        if name not in rooms:
            base, seen = obj.on, {name}
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
    correlation: float | None = None,
) -> World:
    """One ground truth (see the module docstring). ``target_class`` None: any object may be the target.

    Raises :class:`InvalidValueError` for a class the domain does not have, and :class:`DomainError`
    when no object of the target class is in a room the robot can enter."""
    if target_class is not None and target_class not in domain.classes:
        raise InvalidValueError(
            f"unknown target class {target_class!r}; expected one of: {', '.join(sorted(domain.classes))}"
        )
    enterable = {room for room in domain.rooms if domain.rooms[room].accessible}
    rooms, cells = place_objects(domain, space, typical, rng, p_typical=p_typical, correlation=correlation)
    pool = list(domain.objects) if target_class is None else instances_of(domain, target_class)
    candidates = [name for name in pool if rooms[name] in enterable]
    if not candidates:
        what = "objects" if target_class is None else f"objects of class {target_class!r}"
        raise DomainError(
            f"domain {domain.name!r} has no {what} the robot could find (none, or all in rooms marked "
            "'accessible: false'): add one under 'objects:' (without 'room:' to leave its place to chance)"
        )
    target = candidates[int(rng.integers(len(candidates)))]
    chosen_class = target_class if target_class is not None else domain.objects[target].class_
    if absent:
        rooms = {k: v for k, v in rooms.items() if k != target}
        cells = {k: v for k, v in cells.items() if k != target}
    return World(rooms, cells, target, chosen_class, not absent)


def typical_rooms(domain: Domain) -> dict[str, str]:
    """Where the domain's defaults put each object (and where the file puts the others): the
    ``in(O, R)`` the knowledge base holds at step 1, with the defaults. Solves clingo once."""
    from beliefloc.knowledge import KnowledgeBase

    return KnowledgeBase(domain, use_defaults=True).answer().located(step=1)
