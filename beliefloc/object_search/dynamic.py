"""A knowledge base revised during the search: Algorithm 1, lines 7-10 (Zhang, Sridharan & Wyatt 2015,
Sec. III-C2, IV-A "dynamic KB").

While it looks for the target, the robot's detector also looks for the other objects it does not
know the room of (the same detector, the same rates, in the same views). For each such object the
robot keeps a belief over cells exactly as for the target (Eq. 6-7 with a uniform prior over all
cells); summed per room, it says how likely the object is in each room. When that exceeds the
*commit threshold* (:data:`~beliefloc.object_search.settings.COMMIT_THRESHOLD` = 0.9) for a room
the robot can enter, the hypothesis is "elevated from being associated with a high probability to
being associated with complete certainty" (Sec. III-C2): ``in(object, room)`` is committed to the knowledge base
(:meth:`KnowledgeBase.observe <beliefloc.knowledge.KnowledgeBase.observe>`), which is solved
again; the new answer set gives a new room prior for the target (Eq. 5), and the loop revises the
cell belief with it (:meth:`CellBelief.revise <beliefloc.object_search.posterior.CellBelief.revise>`).
A committed object is no longer tracked. A room the robot cannot enter is never committed: nothing
there is ever in view, so only elimination could put mass there.

Roles: :class:`ObjectTracker` is the robot's (pure numpy), :class:`SimulatedObjects
<beliefloc.object_search.world.SimulatedObjects>` the world's, and a :class:`KnowledgeLink` the
knowledge base's -- :class:`KbLink` wraps a :class:`~beliefloc.knowledge.KnowledgeBase` (clingo is
imported only by whoever builds one). :func:`objects_dynamic` puts the three together for one
search, and :func:`dynamic_factory` does it for a single seeded search on a domain.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

from beliefloc.errors import KnowledgeBaseError
from beliefloc.object_search.posterior import Detector
from beliefloc.object_search.settings import COMMIT_THRESHOLD, check_commit_threshold
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.world import SimulatedObjects, place_objects, typical_rooms

if TYPE_CHECKING:
    from beliefloc.knowledge import KnowledgeBase
    from beliefloc.knowledge.domain import Domain


@dataclass
class ObjectTracker:
    """The robot's belief about where each object it does not know the room of stands.

    ``log_likelihood[j, i]``: the kept log-likelihood (Eq. 6, up to a constant per object) of
    object ``names[j]`` being on cell ``i``; the prior over cells is uniform.
    """

    names: tuple[str, ...]
    room_of_cell: np.ndarray
    accessible: np.ndarray
    """``accessible[k]``: room k can be committed (bool, shape (rooms,))."""
    detector: Detector
    threshold: float = COMMIT_THRESHOLD
    log_likelihood: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    active: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    """``active[j]``: object j is still tracked (not committed yet)."""

    def __post_init__(self) -> None:
        check_commit_threshold(self.threshold)
        if self.log_likelihood.shape != (len(self.names), len(self.room_of_cell)):
            self.log_likelihood = np.zeros((len(self.names), len(self.room_of_cell)))
        if len(self.active) != len(self.names):
            self.active = np.ones(len(self.names), dtype=bool)

    @classmethod
    def for_space(cls, space: SearchSpace, names: Sequence[str], threshold: float = COMMIT_THRESHOLD) -> ObjectTracker:
        return cls(tuple(names), space.room_of_cell, space.accessible, space.detector, threshold)

    def room_beliefs(self) -> np.ndarray:
        """``p[j, k]``: object j is in room k (float, shape (objects, rooms)); rows sum to 1."""
        log = self.log_likelihood - self.log_likelihood.max(axis=1, keepdims=True)
        weights = np.exp(log)
        per_room = np.zeros((len(self.names), len(self.accessible)))
        for room in range(len(self.accessible)):  # rooms are few; cells are many
            per_room[:, room] = weights[:, self.room_of_cell == room].sum(axis=1)
        result: np.ndarray = per_room / per_room.sum(axis=1, keepdims=True)
        return result

    def observe(self, cells: np.ndarray, present: np.ndarray) -> list[tuple[str, int]]:
        """Fold in one detection per object for the view covering ``cells``; return the commits
        ``(object, room index)`` this makes (those objects are no longer tracked)."""
        if not self.active.any():
            return []
        ratio = np.where(present, self.detector.log_ratio(True), self.detector.log_ratio(False))
        ratio = np.where(self.active, ratio, 0.0)
        if not np.all(np.isfinite(ratio)):  # a perfect detector: clip so a row never becomes all -inf
            ratio = np.clip(ratio, -50.0, 50.0)
        self.log_likelihood[:, cells] += ratio[:, None]
        beliefs = self.room_beliefs()
        beliefs[:, ~self.accessible] = 0.0
        best = np.argmax(beliefs, axis=1)
        sure = self.active & (beliefs[np.arange(len(self.names)), best] > self.threshold)
        commits = [(self.names[j], int(best[j])) for j in np.flatnonzero(sure)]
        self.active[sure] = False
        return commits


class KnowledgeLink(Protocol):
    """The knowledge base as the search sees it: commit a fact, get the target's new room prior."""

    def commit(self, obj: str, room: str) -> np.ndarray | None:
        """``in(obj, room)`` is now certain; the target's new room prior (axis: the search space's
        rooms), or None when the knowledge base refused the fact (it would have no answer set)."""
        ...


@dataclass
class DynamicKnowledge:
    """Everything lines 7-10 of Algorithm 1 need: the robot's tracker, the world's objects, the KB."""

    tracker: ObjectTracker
    objects: SimulatedObjects
    link: KnowledgeLink
    rejected: list[tuple[str, str]] = field(default_factory=list)
    """Commits the knowledge base refused (it would have had no answer set)."""


PriorCache = dict[frozenset[tuple[str, str]], np.ndarray]
"""Room priors by the set of committed facts: arms of one paired trial that commit the same facts
(the same policy chooses the same views whatever the metareasoning) solve the KB once."""


class KbLink:
    """A :class:`KnowledgeLink` over a clingo :class:`~beliefloc.knowledge.KnowledgeBase`.

    ``make_kb`` builds the knowledge base the first time it is needed (a search that commits
    nothing never grounds one); ``cache`` may be shared by searches on the same knowledge.
    """

    def __init__(
        self,
        make_kb: Callable[[], KnowledgeBase],
        target: str,
        rooms: Sequence[str],
        *,
        cache: PriorCache | None = None,
    ) -> None:
        self._make_kb = make_kb
        self._kb: KnowledgeBase | None = None
        self.target = target
        self.rooms = tuple(rooms)
        self.cache: PriorCache = {} if cache is None else cache
        self.committed: list[tuple[str, str]] = []
        self._applied = 0
        """How many of ``committed`` the knowledge base object has seen."""

    def commit(self, obj: str, room: str) -> np.ndarray | None:
        from beliefloc.knowledge import Observation

        fact = (obj, room)
        if fact in self.committed:
            return None
        key = frozenset([*self.committed, fact])
        cached = self.cache.get(key)
        if cached is None:
            if self._kb is None:
                self._kb = self._make_kb()
            for earlier_obj, earlier_room in self.committed[self._applied :]:
                self._kb.observe(Observation(earlier_obj, earlier_room))
            self._applied = len(self.committed)
            try:
                self._kb.observe(Observation(obj, room))
            except KnowledgeBaseError:
                return None
            self._applied += 1
            prior = self._kb.prior(self.target).prior
            cached = np.array([prior[r] for r in self.rooms])
            self.cache[key] = cached
        self.committed.append(fact)
        return cached.copy()


DynamicFactory = Callable[[np.random.Generator, np.random.Generator], DynamicKnowledge]
"""Builds the dynamic-KB parts of one search from two generators: one to place the other objects,
one for their detections."""


def objects_dynamic(
    space: SearchSpace,
    cells: Mapping[str, int],
    names: Sequence[str],
    link: KnowledgeLink,
    detect_rng: np.random.Generator,
    *,
    threshold: float = COMMIT_THRESHOLD,
    world_detector: Detector | None = None,
) -> DynamicKnowledge:
    """The dynamic-KB parts of one search: the robot tracks ``names``, which stand on ``cells`` (object ->
    cell) in the world and are detected with ``detect_rng`` (at ``world_detector``'s rates; None: the
    robot's model's); commits go through ``link``."""
    where = np.array([cells[name] for name in names], dtype=int)
    return DynamicKnowledge(
        ObjectTracker.for_space(space, names, threshold),
        SimulatedObjects(tuple(names), where, world_detector or space.detector, detect_rng),
        link,
    )


def dynamic_factory(
    domain: Domain, space: SearchSpace, kb: KnowledgeBase, target: str, *, threshold: float = COMMIT_THRESHOLD
) -> DynamicFactory:
    """The dynamic KB of a single seeded search on ``domain``: the domain's
    objects are placed in the world (:func:`~beliefloc.object_search.world.place_objects`; the target
    is another, anonymous instance), the robot tracks those the domain gives no room, and commits go
    to ``kb``, whose room prior of ``target`` the search starts from. Solves clingo once here, for
    the objects' typical rooms."""
    check_commit_threshold(threshold)
    typical = typical_rooms(domain)
    names = [name for name, obj in domain.objects.items() if obj.room is None]

    def factory(place_rng: np.random.Generator, detect_rng: np.random.Generator) -> DynamicKnowledge:
        _, cells = place_objects(domain, space, typical, place_rng)
        link = KbLink(lambda: kb, target, space.rooms)
        return objects_dynamic(space, cells, names, link, detect_rng, threshold=threshold)

    return factory
