"""A domain's scene model attached to its search space: which objects the robot expects in each room,
the SP-POMDP's rates of every view for a target class, and the simulated world's images
(:mod:`beliefloc.object_search.scene` holds the SP-POMDP itself). Pure and seeded, no I/O.

* **The robot's model** of a room's distractors: the objects whose room the domain file gives or
  its defaults conclude (:func:`~beliefloc.object_search.world.typical_rooms`), less the instances
  of the target class (the search is for one instance, as the fixed detector's is: another instance
  of its class is not a distractor but another target, which the paper's world does not have).
* **The world's** distractors: the objects truly in the room (a trial's
  :class:`~beliefloc.object_search.world.World`), less the instances of the target class.
* The SP-POMDP is solved once per (target appearance, distractor distribution) and cached, so every
  view of a room -- and every room that looks alike -- costs one dictionary look-up.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.scene import Appearance, SceneModel, SceneSolver, scene_model, scene_rates
from beliefloc.object_search.settings import Scenes
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.world import SceneTarget, instances_of


def room_classes(
    domain: Domain, rooms: tuple[str, ...], where: Mapping[str, str], target_class: str
) -> tuple[tuple[str, ...], ...]:
    """Per room (axis: ``rooms``), the classes of the objects ``where`` puts there, less the instances
    of ``target_class``; in the domain's object order."""
    excluded = set(instances_of(domain, target_class))
    return tuple(
        tuple(obj.class_ for name, obj in domain.objects.items() if name not in excluded and where.get(name) == room)
        for room in rooms
    )


@dataclass
class SceneSetup:
    """A domain's scene model with its solvers and the robot's expected room contents."""

    domain: Domain
    model: SceneModel
    expected: Mapping[str, str]
    """Object -> the room the robot expects it in (the domain's and its defaults' placement)."""
    solvers: dict[Scenes, SceneSolver] = field(default_factory=dict)
    _spaces: dict[tuple[int, str, Scenes], SearchSpace] = field(default_factory=dict)

    @classmethod
    def of(cls, domain: Domain, expected: Mapping[str, str]) -> SceneSetup | None:
        """The setup of a domain with a scene model (None without)."""
        model = scene_model(domain)
        if model is None:
            return None
        return cls(domain, model, expected)

    def solver(self, mode: Scenes) -> SceneSolver:
        found = self.solvers.get(mode)
        if found is None:
            found = SceneSolver(self.model, apply_all=mode is Scenes.ALL)
            self.solvers[mode] = found
        return found

    def space(self, space: SearchSpace, target_class: str, mode: Scenes) -> SearchSpace:
        """``space`` with the SP-POMDP's rates of every view for ``target_class`` (``mode`` FIXED: ``space``)."""
        if mode is Scenes.FIXED:
            return space
        key = (id(space), target_class, mode)
        found = self._spaces.get(key)
        if found is None:
            classes = room_classes(self.domain, space.rooms, self.expected, target_class)
            rates = scene_rates(self.solver(mode), target_class, space.room_of_cell, classes)
            found = replace(space, scene=rates)
            self._spaces[key] = found
        return found

    def room_looks(
        self, rooms: tuple[str, ...], where: Mapping[str, str], target_class: str
    ) -> tuple[tuple[Appearance, ...], ...]:
        """The appearances of the distractor objects ``where`` puts in each room (the world's side)."""
        classes = room_classes(self.domain, rooms, where, target_class)
        return tuple(tuple(self.model.look(c) for c in per_room) for per_room in classes)

    def world(self) -> Callable[[SearchSpace, int | None, np.random.Generator], SceneTarget]:
        """The world's side of ``search run``: the objects where the robot expects them."""

        def build(space: SearchSpace, cell: int | None, rng: np.random.Generator) -> SceneTarget:
            return self.target(space, cell, self.expected, rng)

        return build

    def target(
        self,
        space: SearchSpace,
        cell: int | None,
        where: Mapping[str, str],
        rng: np.random.Generator,
        *,
        instance: str | None = None,
    ) -> SceneTarget:
        """The world's side of a search on ``space`` (built by :meth:`space`) with the objects where
        ``where`` puts them; ``instance``: the object hidden as the target, which looks like its own
        class (None: like the class searched for)."""
        assert space.scene is not None
        looks = self.room_looks(space.rooms, where, space.scene.target_class)
        look = None if instance is None else self.model.look(self.domain.objects[instance].class_)
        return SceneTarget(cell, self.model, space.scene, space.room_of_cell, looks, rng, look)
