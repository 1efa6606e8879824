"""Ways of choosing the next action during an episode, in one registry.

* ``bestfirst``: Algorithm 1 of Colledanchise et al. -- plan with best-first search, execute the plan
  step by step, replan (keeping the closed list) when an observation differs from the expected one.
* ``uniform``: the same with ``h = 0`` (uniform-cost search), the paper's optimal-cost baseline.
* ``random``: the paper's pseudo-random baseline, alternating a perception action and a random
  actuation action.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from beliefloc.model import Model
from beliefloc.planning.best_first import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    Heuristic,
    PlanResult,
    SearchMemory,
    plan,
)
from beliefloc.planning.successors import SuccessorEvaluator


@dataclass(frozen=True)
class GiveUp:
    """A strategy's honest 'I cannot go on', with the reason as a status word."""

    status: str


class Strategy(Protocol):
    name: str
    plan_seconds: list[float]
    new_plan: PlanResult | None
    """The plan made while choosing the last action, if one was made."""

    def next_action(self, belief: np.ndarray) -> str | GiveUp: ...

    def observed(self, action: str, observation: int | None, belief: np.ndarray) -> None: ...


@dataclass(frozen=True)
class PlannerSettings:
    threshold: float = DEFAULT_THRESHOLD
    heuristic: Heuristic = Heuristic.ENTROPY_MAX_PROB
    max_expansions: int = DEFAULT_MAX_EXPANSIONS
    time_limit: float = DEFAULT_TIME_LIMIT


@dataclass
class PlanningStrategy:
    """Plan, act, perceive and replan when the world surprises us (Algorithm 1, ``Main``)."""

    name: str
    model: Model
    settings: PlannerSettings
    evaluator: SuccessorEvaluator
    plan_seconds: list[float] = field(default_factory=list)
    plans: list[PlanResult] = field(default_factory=list)
    memory: SearchMemory = field(default_factory=SearchMemory)
    new_plan: PlanResult | None = None
    _current: PlanResult | None = None
    _index: int = 0

    def next_action(self, belief: np.ndarray) -> str | GiveUp:
        self.new_plan = None
        if self._current is None or self._index >= len(self._current.steps):
            s = self.settings
            result = plan(
                self.model,
                belief,
                threshold=s.threshold,
                heuristic=s.heuristic,
                max_expansions=s.max_expansions,
                time_limit=s.time_limit,
                memory=self.memory,
                evaluator=self.evaluator,
            )
            self.plans.append(result)
            self.plan_seconds.append(result.seconds)
            self.new_plan = result
            if not result.found or not result.steps:
                return GiveUp(result.status.value)
            self._current, self._index = result, 0
        return self._current.steps[self._index].action

    def observed(self, action: str, observation: int | None, belief: np.ndarray) -> None:
        assert self._current is not None
        expected = self._current.steps[self._index].observation_index
        self._index += 1
        if observation != expected:
            self._current = None  # the belief differs from the one the plan expected: replan

    @property
    def replans(self) -> int:
        return max(0, len(self.plans) - 1)


@dataclass
class RandomStrategy:
    """Perceive, then move at random, in turn (the authors' pseudo-random baseline)."""

    name: str
    model: Model
    rng: np.random.Generator
    plan_seconds: list[float] = field(default_factory=list)
    new_plan: PlanResult | None = None
    _turn: int = 0

    def next_action(self, belief: np.ndarray) -> str | GiveUp:
        start = time.perf_counter()
        perceive = self._turn % 2 == 0 and self.model.perception_actions
        choices = self.model.perception_actions if perceive else self.model.actuation_actions
        self._turn += 1
        action = choices[int(self.rng.integers(len(choices)))].name
        self.plan_seconds.append(time.perf_counter() - start)
        return action

    def observed(self, action: str, observation: int | None, belief: np.ndarray) -> None:
        return None

    @property
    def replans(self) -> int:
        return 0


StrategyFactory = Callable[[Model, PlannerSettings, SuccessorEvaluator, np.random.Generator], Strategy]


def _planner(name: str, heuristic: Heuristic | None) -> StrategyFactory:
    def make(
        model: Model, settings: PlannerSettings, evaluator: SuccessorEvaluator, rng: np.random.Generator
    ) -> Strategy:
        chosen = (
            settings
            if heuristic is None
            else PlannerSettings(settings.threshold, heuristic, settings.max_expansions, settings.time_limit)
        )
        return PlanningStrategy(name, model, chosen, evaluator)

    return make


def _random(
    model: Model, settings: PlannerSettings, evaluator: SuccessorEvaluator, rng: np.random.Generator
) -> Strategy:
    return RandomStrategy("random", model, rng)


STRATEGIES: dict[str, StrategyFactory] = {
    "bestfirst": _planner("bestfirst", None),
    "uniform": _planner("uniform", Heuristic.ZERO),
    "random": _random,
}
"""Every strategy ``simulate`` offers, by name."""
