"""Robots: anything that can execute an action and report what it observed.

The planner's model and the world need not be the same: a :class:`SimulatedRobot` may be given a
different (e.g. noisier) model than the one the planner uses. A log replay or a real robot is just
another implementation of :class:`Robot`.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from beliefloc.model import Model


class Robot(Protocol):
    def act(self, action: str) -> int | None:
        """Execute ``action``; return the observation index (None when it observes nothing)."""
        ...


class SimulatedRobot:
    """A robot in a simulated world: it owns the true state and its own seeded generator.

    Acting samples the next state from row ``state`` of ``T_a`` and then each observation part's
    reading from its confusion row, exactly the generative model the belief update inverts.
    """

    def __init__(self, world: Model, state: int, rng: np.random.Generator) -> None:
        self.world = world
        self.state = state
        self.rng = rng

    def act(self, action: str) -> int | None:
        act = self.world.action(action)
        if act.transition is not None:
            t = act.transition
            start, end = t.indptr[self.state], t.indptr[self.state + 1]
            columns, weights = t.indices[start:end], t.data[start:end]
            self.state = int(columns[_draw(self.rng, weights)])
        parts = act.observation.parts
        if not parts:
            return None
        readings = [_draw(self.rng, part.confusion[part.truth[self.state]]) for part in parts]
        return act.observation.encode(readings)


def _draw(rng: np.random.Generator, weights: np.ndarray) -> int:
    """Index i with probability weights[i] (weights sum to 1)."""
    cumulative = np.cumsum(weights)
    return int(min(np.searchsorted(cumulative, rng.random() * cumulative[-1], side="right"), len(weights) - 1))
