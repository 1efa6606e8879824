"""Ways of choosing the next action during an episode, in one registry.

* ``bestfirst``: Algorithm 1 of Colledanchise et al. -- plan with best-first search, execute the plan
  step by step, replan (keeping the closed list) when an observation differs from the expected one.
* ``uniform``: the same with ``h = 0`` (uniform-cost search), the paper's optimal-cost baseline.
* ``random``: the paper's pseudo-random baseline, alternating a perception action and a random
  actuation action.
* ``ec2``: Khalvati & Mackworth's Algorithm 1 -- the heaviest action by the pairwise edge weights
  (:mod:`beliefloc.planning.ec2`), a random basic action when no action has a positive weight.
* ``contingent``: a policy that branches on every observation (:mod:`beliefloc.planning.contingent`),
  planned ``lookahead`` expansions at a time and followed branch by branch. One planner serves the
  whole episode and keeps its graph: while the policy is incomplete (it has frontier leaves) every step
  plans ``lookahead`` expansions more from the robot's belief, and the robot also plans at a leaf
  that is not a goal (an observation the policy did not plan for, or a dead end).
* ``ec2-macros``: their Algorithm 3 -- macros (:mod:`beliefloc.planning.macros`) are candidates too;
  a chosen macro is executed one basic action at a time and abandoned when an observation differs
  from the one expected (the noise-free observation of the most likely state's path).
"""

from __future__ import annotations

import enum
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from beliefloc.model import Model
from beliefloc.planning.best_first import ClosedList, PlanResult, PlanStatus, PlanStep, plan
from beliefloc.planning.contingent import (
    InformationPrices,
    PolicyNode,
    PolicyPlanner,
    PolicyResult,
    information_prices,
)
from beliefloc.planning.ec2 import PairContext, hypotheses, pair_context, select
from beliefloc.planning.macros import MacroTable, PairMacros, macro_candidates, pair_macros
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_MAX_HYPOTHESES,
    DEFAULT_PRUNE_BELOW,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Heuristic,
    default_lookahead,
)
from beliefloc.planning.successors import SuccessorEvaluator
from beliefloc.simulation.settings import StrategyName


class EpisodeStatus(enum.Enum):
    """How an episode ended."""

    LOCALIZED = "localized"
    """One state holds at least the threshold."""
    NO_PLAN = "no_plan"
    """The planner searched every reachable belief and none reaches the threshold."""
    BUDGET_EXCEEDED = "budget_exceeded"
    """The planner's expansion or time budget ran out."""
    STEP_LIMIT = "step_limit"
    """The episode took its maximum number of actions."""
    IMPOSSIBLE_OBSERVATION = "impossible_observation"
    """The world gave an observation the robot's model says cannot happen (a world unlike the model)."""
    INCONSISTENT = "inconsistent"
    """The readings stopped fitting the belief, and re-spreading it did not help (a world unlike the
    model: :mod:`beliefloc.robots.surprise`)."""


@dataclass(frozen=True)
class GiveUp:
    """A strategy's honest 'I cannot go on', with the reason."""

    status: EpisodeStatus


class Strategy(Protocol):
    """What the episode loop reads from a strategy (:func:`beliefloc.simulation.episode.run_episode`)."""

    name: str
    plan_seconds: list[float]
    """Seconds spent choosing each action (or planning), Table I's metric."""
    new_plan: PlanResult | None
    """The plan made while choosing the last action, if one was made."""

    @property
    def replans(self) -> int:
        """How often the strategy dropped what it meant to do because the world surprised it."""
        ...

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
    lookahead: int | None = None
    """``contingent``: beliefs expanded per plan call, one call per step while the policy is
    incomplete (within ``max_expansions``); None:
    :func:`beliefloc.planning.settings.default_lookahead` of the model's size."""
    prune_below: float = DEFAULT_PRUNE_BELOW
    """``contingent``: observation branches less likely than this are not planned for."""
    anytime: bool = True
    """Best-first strategies: when a plan call's budget runs out, act on the best partial plan by its
    estimate (:attr:`beliefloc.planning.best_first.PlanResult.partial`) and plan again after it,
    instead of giving up (False: the strategy of before issue 28, kept for side-by-side benchmarks)."""
    max_time_limit: float | None = None
    """Anytime: after a plan call out of budget, the next call gets twice the seconds, up to this
    (back to ``time_limit`` after a complete plan): a robot that keeps getting partial plans searches
    deeper from each belief instead of turning back and forth. None: every call gets ``time_limit``."""
    partial_steps: int | None = 1
    """Anytime: how many steps of a partial plan to follow before planning again (None: all of them,
    while the observations are the expected ones). 1, the best action found so far and then a new
    search from the belief it leads to: on the depot (0.5 s a call) following whole partial plans cost
    788.5 over six hard episodes, their first steps 455 (today's complete plans: 367.5)."""


@dataclass
class PlanningStrategy:
    """Plan, act, perceive and replan when the world surprises us (Algorithm 1, ``Main``).

    Anytime (``settings.anytime``): a plan call whose budget runs out still returns the best partial
    plan by its estimate; the strategy follows it as it follows a complete one (while the observations
    are the expected ones) and plans again at its end, so it gives up only when the search proves
    there is no plan."""

    name: str
    model: Model
    settings: PlannerSettings
    evaluator: SuccessorEvaluator
    plan_seconds: list[float] = field(default_factory=list)
    plans: list[PlanResult] = field(default_factory=list)
    memory: ClosedList = field(default_factory=ClosedList)
    new_plan: PlanResult | None = None
    _current: PlanResult | None = None
    _index: int = 0
    _time_limit: float | None = None

    def next_action(self, belief: np.ndarray) -> str | GiveUp:
        self.new_plan = None
        if self._current is None or self._index >= len(self._current.steps):
            s = self.settings
            time_limit = self._time_limit or s.time_limit
            result = plan(
                self.model,
                belief,
                threshold=s.threshold,
                heuristic=s.heuristic,
                max_expansions=s.max_expansions,
                time_limit=time_limit,
                memory=self.memory,
                evaluator=self.evaluator,
                weight=s.weight,
            )
            self.plans.append(result)
            self.plan_seconds.append(result.seconds)
            self.new_plan = result
            usable = result.found or (s.anytime and result.partial)
            if not usable or not result.steps:
                return GiveUp(EpisodeStatus(result.status.value))
            if result.partial and s.max_time_limit is not None:
                self._time_limit = min(2.0 * time_limit, max(s.max_time_limit, s.time_limit))
            elif result.found:
                self._time_limit = None
            if result.partial and s.partial_steps is not None:
                result = replace(result, steps=result.steps[: s.partial_steps])
            self._current, self._index = result, 0
        return self._current.steps[self._index].action

    @property
    def current_step(self) -> PlanStep | None:
        """The plan step whose action :meth:`next_action` returned (with the observation the plan
        expects after it); None before the first plan or once the plan is used up."""
        if self._current is None or self._index >= len(self._current.steps):
            return None
        return self._current.steps[self._index]

    @property
    def following_step(self) -> PlanStep | None:
        """The plan step after :attr:`current_step` (None when there is none)."""
        if self._current is None or self._index + 1 >= len(self._current.steps):
            return None
        return self._current.steps[self._index + 1]

    def observed(self, action: str, observation: int | None, belief: np.ndarray) -> None:
        step = self.current_step
        assert step is not None
        expected = step.observation_index
        self._index += 1
        if observation != expected:
            self._current = None  # the belief differs from the one the plan expected: replan

    @property
    def replans(self) -> int:
        return max(0, len(self.plans) - 1)


@dataclass
class ContingentStrategy:
    """Follow a contingent policy branch by branch, and go on planning with the same
    :class:`PolicyPlanner` (which keeps its graph) at every step while the policy is incomplete, and at
    a leaf that is not a goal (:mod:`beliefloc.planning.contingent`). Planning on from each belief the
    robot reaches spends the lookahead where the episode goes: on the hallway, one call of 937
    expansions from the start leaves 88 % of the policy's probability at frontier leaves."""

    name: str
    model: Model
    settings: PlannerSettings
    evaluator: SuccessorEvaluator
    prices: InformationPrices
    plan_seconds: list[float] = field(default_factory=list)
    policies: list[PolicyResult] = field(default_factory=list)
    new_plan: PlanResult | None = None
    _node: PolicyNode | None = None
    _planner: PolicyPlanner | None = None

    def next_action(self, belief: np.ndarray) -> str | GiveUp:
        complete = bool(self.policies) and self.policies[-1].found
        if self._node is None or self._node.action is None or not complete:
            s = self.settings
            if self._planner is None:
                self._planner = PolicyPlanner(
                    self.model,
                    threshold=s.threshold,
                    heuristic=s.heuristic,
                    prune_below=s.prune_below,
                    evaluator=self.evaluator,
                    prices=self.prices,
                )
            result = self._planner.plan(
                belief,
                max_expansions=min(s.lookahead or default_lookahead(self.model.n_states), s.max_expansions),
                time_limit=s.time_limit,
            )
            self.policies.append(result)
            self.plan_seconds.append(result.seconds)
            if result.root.action is None:
                status = PlanStatus.NO_PLAN if result.status is PlanStatus.NO_PLAN else PlanStatus.BUDGET_EXCEEDED
                return GiveUp(EpisodeStatus(status.value))
            self._node = result.root
        assert self._node.action is not None
        return self._node.action

    def observed(self, action: str, observation: int | None, belief: np.ndarray) -> None:
        assert self._node is not None
        branch = self._node.branch(observation)
        self._node = None if branch is None else branch.node

    @property
    def replans(self) -> int:
        return max(0, len(self.policies) - 1)


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
    table: PairMacros | None = None
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


@dataclass
class SharedWork:
    """What the episodes of one experiment share, computed once: the successor evaluator and, per
    distinguishability threshold, EC2's pair context and the macro table built from it."""

    model: Model
    evaluator: SuccessorEvaluator
    _contexts: dict[float | None, PairContext] = field(default_factory=dict)
    _macros: dict[float | None, PairMacros] = field(default_factory=dict)
    _prices: InformationPrices | None = None

    @classmethod
    def for_model(cls, model: Model) -> SharedWork:
        return cls(model, SuccessorEvaluator(model))

    def pair_context(self, gamma: float | None) -> PairContext:
        if gamma not in self._contexts:
            self._contexts[gamma] = pair_context(self.model, gamma)
        return self._contexts[gamma]

    def information_prices(self) -> InformationPrices:
        """The contingent planner's costs per nat (:func:`beliefloc.planning.contingent.information_prices`)."""
        if self._prices is None:
            self._prices = information_prices(self.model, self.evaluator)
        return self._prices

    def macros(self, gamma: float | None) -> PairMacros:
        """The macro table, or where its pairs would be too many, a search per pair asked for."""
        if gamma not in self._macros:
            self._macros[gamma] = pair_macros(self.model, self.pair_context(gamma))
        return self._macros[gamma]


StrategyFactory = Callable[[StrategyName, PlannerSettings, SharedWork, np.random.Generator], Strategy]


def _ec2(with_macros: bool) -> StrategyFactory:
    def make(name: StrategyName, settings: PlannerSettings, shared: SharedWork, rng: np.random.Generator) -> Strategy:
        given = settings.macros
        gamma = given.gamma if given is not None else settings.gamma
        context = shared.pair_context(gamma)
        table: PairMacros | None = given
        if with_macros and table is None:
            table = shared.macros(gamma)
        return EC2Strategy(
            name.value,
            shared.model,
            context,
            rng,
            table if with_macros else None,
            max_hypotheses=settings.max_hypotheses,
        )

    return make


def _planner(heuristic: Heuristic | None) -> StrategyFactory:
    def make(name: StrategyName, settings: PlannerSettings, shared: SharedWork, rng: np.random.Generator) -> Strategy:
        chosen = settings if heuristic is None else replace(settings, heuristic=heuristic)
        return PlanningStrategy(name.value, shared.model, chosen, shared.evaluator)

    return make


def _contingent(
    name: StrategyName, settings: PlannerSettings, shared: SharedWork, rng: np.random.Generator
) -> Strategy:
    return ContingentStrategy(name.value, shared.model, settings, shared.evaluator, shared.information_prices())


def _random(name: StrategyName, settings: PlannerSettings, shared: SharedWork, rng: np.random.Generator) -> Strategy:
    return RandomStrategy(name.value, shared.model, rng)


STRATEGIES: dict[StrategyName, StrategyFactory] = {
    StrategyName.BESTFIRST: _planner(None),
    StrategyName.UNIFORM: _planner(Heuristic.ZERO),
    StrategyName.RANDOM: _random,
    StrategyName.EC2: _ec2(with_macros=False),
    StrategyName.EC2_MACROS: _ec2(with_macros=True),
    StrategyName.CONTINGENT: _contingent,
}
"""Every strategy ``simulate`` offers, one per :class:`StrategyName`."""


def make_strategy(
    name: StrategyName, settings: PlannerSettings, shared: SharedWork, rng: np.random.Generator
) -> Strategy:
    """A fresh strategy for one episode."""
    return STRATEGIES[name](name, settings, shared, rng)
