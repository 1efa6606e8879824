"""Paired object-search trials: their random streams and what the robot knows of each trial's world
(Zhang, Sridharan & Wyatt 2015, Sec. IV-A). Pure and seeded: no clingo, no I/O; randomness only
through passed Generators.

A trial's ground truth is the simulated world's (:func:`~beliefloc.object_search.world.sample_world`);
what the *robot knows* of it is this module's:

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

import numpy as np

from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.settings import check_fraction
from beliefloc.object_search.world import World


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


def sample_known(domain: Domain, world: World, fraction: float, rng: np.random.Generator) -> frozenset[str]:
    """The objects whose true room the robot knows: ``round(fraction x n)`` of the ``n`` objects other
    than the target, drawn uniformly."""
    check_fraction("the fraction of known objects", fraction)
    others = [name for name in domain.objects if name != world.target]
    count = round(fraction * len(others))
    chosen = rng.choice(len(others), size=count, replace=False) if count else np.zeros(0, dtype=int)
    return frozenset(others[int(i)] for i in chosen)


def robot_domain(domain: Domain, world: World, known: frozenset[str]) -> Domain:
    """The domain as the robot knows it: every object, with its true room only when it is ``known``,
    and no ``on`` facts (a validated domain copied, not re-read)."""
    objects = {
        name: obj.model_copy(update={"room": world.rooms[name] if name in known else None, "on": None})
        for name, obj in domain.objects.items()
    }
    return domain.model_copy(update={"objects": objects})


def unknown_objects(domain: Domain, world: World, known: frozenset[str]) -> list[str]:
    """The objects of the world the robot may learn about during a search (dynamic KB): those whose
    room it does not know, but the target."""
    return [name for name in domain.objects if name in world.rooms and name not in known and name != world.target]
