"""Episodes and paired experiments: every strategy runs on the same seeded starts and noise.

An episode: the robot starts in a true state unknown to it; from the start belief the strategy
chooses an action, the simulated robot executes it and reports an observation, the belief is
updated, and so on until ``max(b) >= threshold`` (localized), the strategy gives up (no plan,
budget exceeded), or a step limit. Records are plain data; statistics are computed from them.
"""

from __future__ import annotations

import statistics
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from beliefloc.belief import most_likely, update
from beliefloc.errors import ImpossibleObservationError
from beliefloc.model import Model
from beliefloc.planning.best_first import PlanResult
from beliefloc.planning.successors import SuccessorEvaluator
from beliefloc.simulation.robot import SimulatedRobot
from beliefloc.simulation.strategies import STRATEGIES, GiveUp, PlannerSettings

DEFAULT_MAX_STEPS = 200


@dataclass(frozen=True)
class StepRecord:
    action: str
    observation: str | None
    probability: float
    max_belief: float
    true_state: str
    plan: PlanResult | None = None
    """The plan made before this step (the first plan, or a replan), if any."""


@dataclass
class EpisodeRecord:
    strategy: str
    episode: int
    start: str
    final: str
    """The most likely state at the end."""
    true_final: str
    correct: bool
    """The most likely state is the robot's true state."""
    status: str
    """``localized``, ``no_plan``, ``budget_exceeded``, ``step_limit`` or ``impossible_observation``."""
    cost: float
    steps: int
    replans: int
    plan_seconds: list[float]
    max_belief: float
    trace: list[StepRecord] = field(default_factory=list)

    def as_json(self) -> dict[str, Any]:
        data = asdict(self)
        data.pop("trace")
        return data


OnStep = Callable[[EpisodeRecord, StepRecord, np.ndarray], None]


def episode_rngs(seed: int, episode: int) -> tuple[np.random.Generator, np.random.Generator, np.random.Generator]:
    """Independent generators for (start state, world noise, strategy) of one episode."""
    start, world, strategy = np.random.SeedSequence([seed, episode]).spawn(3)
    return np.random.default_rng(start), np.random.default_rng(world), np.random.default_rng(strategy)


def run_episode(
    model: Model,
    strategy_name: str,
    start_state: int,
    start_belief: np.ndarray,
    *,
    seed: int,
    episode: int = 0,
    world: Model | None = None,
    settings: PlannerSettings | None = None,
    evaluator: SuccessorEvaluator | None = None,
    max_steps: int = DEFAULT_MAX_STEPS,
    on_step: OnStep | None = None,
) -> EpisodeRecord:
    """One episode of ``strategy_name`` from ``start_state`` (the robot's secret)."""
    settings = settings or PlannerSettings()
    _, world_rng, strategy_rng = episode_rngs(seed, episode)
    robot = SimulatedRobot(world or model, start_state, world_rng)
    strategy = STRATEGIES[strategy_name](model, settings, evaluator or SuccessorEvaluator(model), strategy_rng)
    names = model.states
    record = EpisodeRecord(strategy_name, episode, names.name(start_state), "", "", False, "", 0.0, 0, 0, [], 0.0)
    belief = start_belief
    status = "localized"
    while belief.max() < settings.threshold:
        if record.steps >= max_steps:
            status = "step_limit"
            break
        decision = strategy.next_action(belief)
        if isinstance(decision, GiveUp):
            status = decision.status
            break
        action = model.action(decision)
        observation = robot.act(decision)
        try:
            belief, probability = update(model, belief, action, observation)
        except ImpossibleObservationError:
            status = "impossible_observation"
            break
        record.steps += 1
        record.cost += action.cost
        strategy.observed(decision, observation, belief)
        step = StepRecord(
            decision,
            None if observation is None else action.observation.name(observation),
            probability,
            float(belief.max()),
            names.name(robot.state),
            strategy.new_plan,
        )
        record.trace.append(step)
        if on_step is not None:
            on_step(record, step, belief)
    state, probability = most_likely(belief)
    record.final = names.name(state)
    record.true_final = names.name(robot.state)
    record.correct = state == robot.state
    record.status = status
    record.max_belief = probability
    record.plan_seconds = list(strategy.plan_seconds)
    record.replans = int(getattr(strategy, "replans", 0))
    return record


def run_experiment(
    model: Model,
    strategies: Sequence[str],
    *,
    episodes: int,
    seed: int,
    start: int | None = None,
    start_belief: np.ndarray | None = None,
    start_distribution: np.ndarray | None = None,
    world: Model | None = None,
    settings: PlannerSettings | None = None,
    max_steps: int = DEFAULT_MAX_STEPS,
    on_step: OnStep | None = None,
    on_episode: Callable[[EpisodeRecord], None] | None = None,
) -> list[EpisodeRecord]:
    """Paired trials: in episode e every strategy starts from the same true state and meets the
    same seeded noise stream. ``start=None`` draws the true start per episode, from
    ``start_distribution`` (a probability per state) when given, else uniformly."""
    evaluator = SuccessorEvaluator(model)
    belief = start_belief if start_belief is not None else np.full(model.n_states, 1.0 / model.n_states)
    records = []
    for e in range(episodes):
        start_rng, _, _ = episode_rngs(seed, e)
        if start is not None:
            state = start
        elif start_distribution is not None:
            state = int(start_rng.choice(model.n_states, p=start_distribution))
        else:
            state = int(start_rng.integers(model.n_states))
        for name in strategies:
            record = run_episode(
                model,
                name,
                state,
                belief,
                seed=seed,
                episode=e,
                world=world,
                settings=settings,
                evaluator=evaluator,
                max_steps=max_steps,
                on_step=on_step,
            )
            records.append(record)
            if on_episode is not None:
                on_episode(record)
    return records


def summarize(records: Sequence[EpisodeRecord]) -> dict[str, dict[str, Any]]:
    """Per strategy: localized correctly, plan time (Table I's metric: per episode the mean over its
    plan calls, then mean and spread over episodes), replans, cost, steps and failures."""
    out: dict[str, dict[str, Any]] = {}
    for name in dict.fromkeys(r.strategy for r in records):
        mine = [r for r in records if r.strategy == name]
        localized = [r for r in mine if r.status == "localized"]
        per_episode_plan = [statistics.fmean(r.plan_seconds) for r in mine if r.plan_seconds]
        out[name] = {
            "episodes": len(mine),
            "localized": len(localized),
            "correct": sum(r.correct for r in mine),
            "failures": {
                s: sum(r.status == s for r in mine) for s in sorted({r.status for r in mine}) if s != "localized"
            },
            "mean_plan_seconds": _mean(per_episode_plan),
            "stdev_plan_seconds": _stdev(per_episode_plan),
            "mean_replans": _mean([r.replans for r in mine]),
            "mean_cost": _mean([r.cost for r in localized]),
            "stdev_cost": _stdev([r.cost for r in localized]),
            "mean_steps": _mean([r.steps for r in localized]),
        }
    return out


def _mean(values: Sequence[float]) -> float | None:
    return statistics.fmean(values) if values else None


def _stdev(values: Sequence[float]) -> float | None:
    return statistics.stdev(values) if len(values) > 1 else None
