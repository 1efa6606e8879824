"""Ways of choosing the next action during an episode, in one registry.

* ``bestfirst``: Algorithm 1 of Colledanchise et al. -- plan with best-first search, execute the plan
  step by step, replan (keeping the closed list) when an observation differs from the expected one.
* ``uniform``: the same with ``h = 0`` (uniform-cost search), the paper's optimal-cost baseline.
* ``random``: the paper's pseudo-random baseline, alternating a perception action and a random
  actuation action.
* ``ec2``: Khalvati & Mackworth's Algorithm 1 -- the heaviest action by the pairwise edge weights
  (:mod:`beliefloc.planning.ec2`), a random basic action when no action has a positive weight.
* ``ec2-macros``: their Algorithm 3 -- macros (:mod:`beliefloc.planning.macros`) are candidates too;
  a chosen macro is executed one basic action at a time and abandoned when an observation differs
  from the one expected (the noise-free observation of the most likely state's path).
"""

from __future__ import annotations

import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from beliefloc.model import Model
from beliefloc.planning.best_first import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Heuristic,
    PlanResult,
    SearchMemory,
    plan,
)
from beliefloc.planning.ec2 import DEFAULT_MAX_HYPOTHESES, PairContext, hypotheses, pair_context, select
from beliefloc.planning.macros import MacroTable, build_macros, macro_candidates
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
    gamma: float | None = None
    """EC2's distinguishability threshold; None: :func:`beliefloc.planning.ec2.default_gamma`."""
    macros: MacroTable | None = None
    """``ec2-macros``: the macro table (built for the model when None)."""
    max_hypotheses: int = DEFAULT_MAX_HYPOTHESES
    """EC2: Sec. VII-B's reduction to the most likely states."""
    weight: float = DEFAULT_WEIGHT
    """Best-first search ranks nodes by ``g + weight · h`` (1: the paper's)."""


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
                weight=s.weight,
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


@dataclass
class EC2Strategy:
    """Khalvati & Mackworth's Algorithms 1 and 3: choose by edge weights, run macros step by step."""

    name: str
    model: Model
    context: PairContext
    rng: np.random.Generator
    table: MacroTable | None = None
    max_hypotheses: int = DEFAULT_MAX_HYPOTHESES
    plan_seconds: list[float] = field(default_factory=list)
    new_plan: PlanResult | None = None
    replans: int = 0
    """Macros abandoned because an observation differed from the expected one."""
    random_actions: int = 0
    macros_started: int = 0
    _queue: list[int] = field(default_factory=list)
    _expected: list[int | None] = field(default_factory=list)

    def next_action(self, belief: np.ndarray) -> str | GiveUp:
        if self._queue:
            return self.model.actions[self._queue[0]].name
        start = time.perf_counter()
        candidates: list[tuple[int, ...]] = []
        if self.table is not None:
            states = hypotheses(belief, max_hypotheses=self.max_hypotheses)
            candidates = macro_candidates(self.table, states, belief)
        result = select(self.context, belief, candidates, max_hypotheses=self.max_hypotheses)
        if result.chosen is None:  # Algorithm 1's baseline: nothing helps, move at random
            self.random_actions += 1
            chosen: tuple[int, ...] = (int(self.rng.integers(len(self.model.actions))),)
            macro = False
        else:
            candidate = result.candidates[result.chosen]
            chosen, macro = candidate.actions, candidate.macro
        self._queue = list(chosen)
        self._expected = [None] * len(chosen)
        if macro:
            self.macros_started += 1
            state = int(np.argmax(belief))
            for k, a in enumerate(chosen[:-1]):
                state = int(self.context.fstar[a, state])
                observation = self.model.actions[a].observation
                self._expected[k] = observation.true_observation(state) if observation.parts else None
        self.plan_seconds.append(time.perf_counter() - start)
        return self.model.actions[self._queue[0]].name

    def observed(self, action: str, observation: int | None, belief: np.ndarray) -> None:
        if not self._queue:
            return
        self._queue.pop(0)
        expected = self._expected.pop(0)
        if self._queue and expected is not None and observation != expected:
            self.replans += 1  # the action did not go as expected: abandon the macro
            self._queue, self._expected = [], []


_CONTEXTS: weakref.WeakKeyDictionary[Model, dict[tuple[str, float | None], object]] = weakref.WeakKeyDictionary()
"""Per model, the pair context and the built macro table, shared by the episodes of an experiment."""


def _cached(model: Model, key: tuple[str, float | None], make: Callable[[], object]) -> object:
    store = _CONTEXTS.setdefault(model, {})
    if key not in store:
        store[key] = make()
    return store[key]


def _ec2(name: str, with_macros: bool) -> StrategyFactory:
    def make(
        model: Model, settings: PlannerSettings, evaluator: SuccessorEvaluator, rng: np.random.Generator
    ) -> Strategy:
        table = settings.macros
        gamma = table.gamma if table is not None else settings.gamma
        context = _cached(model, ("context", gamma), lambda: pair_context(model, gamma))
        assert isinstance(context, PairContext)
        if with_macros and table is None:
            built = _cached(model, ("macros", gamma), lambda: build_macros(model, gamma, context=context))
            assert isinstance(built, MacroTable)
            table = built
        return EC2Strategy(
            name, model, context, rng, table if with_macros else None, max_hypotheses=settings.max_hypotheses
        )

    return make


StrategyFactory = Callable[[Model, PlannerSettings, SuccessorEvaluator, np.random.Generator], Strategy]


def _planner(name: str, heuristic: Heuristic | None) -> StrategyFactory:
    def make(
        model: Model, settings: PlannerSettings, evaluator: SuccessorEvaluator, rng: np.random.Generator
    ) -> Strategy:
        chosen = settings if heuristic is None else replace(settings, heuristic=heuristic)
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
    "ec2": _ec2("ec2", with_macros=False),
    "ec2-macros": _ec2("ec2-macros", with_macros=True),
}
"""Every strategy ``simulate`` offers, by name."""
