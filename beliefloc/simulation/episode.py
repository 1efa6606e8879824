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
from beliefloc.errors import ImpossibleObservationError, InvalidValueError
from beliefloc.model import Model
from beliefloc.planning.best_first import PlanResult
from beliefloc.pose import PoseEstimate, belief_pose
from beliefloc.simulation.robot import SimulatedRobot
from beliefloc.simulation.settings import DEFAULT_MAX_STEPS, StrategyName
from beliefloc.simulation.strategies import EpisodeStatus, GiveUp, PlannerSettings, SharedWork, make_strategy


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
    status: EpisodeStatus
    cost: float
    steps: int
    replans: int
    plan_seconds: list[float]
    max_belief: float
    trace: list[StepRecord] = field(default_factory=list)
    pose: PoseEstimate | None = None
    """The final belief as a pose: its most likely state's (:attr:`final`) and its covariance;
    None for a model without a grid."""

    def as_json(self, *, timings: bool = True) -> dict[str, Any]:
        """What ``simulate --json`` prints per episode; without ``timings`` no clock value.
        ``"pose"`` is :meth:`PoseEstimate.as_json` of the final belief (null without a grid)."""
        data = asdict(self)
        data.pop("trace")
        data["status"] = self.status.value
        data["pose"] = None if self.pose is None else self.pose.as_json()
        if not timings:
            data["plan_seconds"] = None
        return data


OnStep = Callable[[EpisodeRecord, StepRecord, np.ndarray], None]


def episode_rngs(seed: int, episode: int) -> tuple[np.random.Generator, np.random.Generator, np.random.Generator]:
    """Independent generators for (start state, world noise, strategy) of one episode."""
    start, world, strategy = np.random.SeedSequence([seed, episode]).spawn(3)
    return np.random.default_rng(start), np.random.default_rng(world), np.random.default_rng(strategy)


def strategy_name(text: str) -> StrategyName:
    """The strategy called ``text`` (:class:`InvalidValueError` listing the names otherwise); a
    :class:`StrategyName` is returned as it is."""
    try:
        return StrategyName(text)
    except ValueError:
        names = ", ".join(s.value for s in StrategyName)
        raise InvalidValueError(f"unknown strategy {text!r}; expected one of: {names}") from None


def run_episode(
    model: Model,
    strategy: str,
    start_state: int,
    start_belief: np.ndarray,
    *,
    seed: int,
    episode: int = 0,
    world: Model | None = None,
    settings: PlannerSettings | None = None,
    shared: SharedWork | None = None,
    max_steps: int = DEFAULT_MAX_STEPS,
    on_step: OnStep | None = None,
) -> EpisodeRecord:
    """One episode of the strategy named ``strategy`` from ``start_state`` (the robot's secret)."""
    settings = settings or PlannerSettings()
    _, world_rng, strategy_rng = episode_rngs(seed, episode)
    robot = SimulatedRobot(world or model, start_state, world_rng)
    name = strategy_name(strategy)
    chooser = make_strategy(name, settings, shared or SharedWork.for_model(model), strategy_rng)
    names = model.states
    record = EpisodeRecord(
        name.value,
        episode,
        names.name(start_state),
        "",
        "",
        False,
        EpisodeStatus.LOCALIZED,
        0.0,
        0,
        0,
        [],
        0.0,
    )
    belief = start_belief
    status = EpisodeStatus.LOCALIZED
    while belief.max() < settings.threshold:
        if record.steps >= max_steps:
            status = EpisodeStatus.STEP_LIMIT
            break
        decision = chooser.next_action(belief)
        if isinstance(decision, GiveUp):
            status = decision.status
            break
        action = model.action(decision)
        observation = robot.act(decision)
        try:
            belief, probability = update(model, belief, action, observation)
        except ImpossibleObservationError:
            status = EpisodeStatus.IMPOSSIBLE_OBSERVATION
            break
        record.steps += 1
        record.cost += action.cost
        chooser.observed(decision, observation, belief)
        step = StepRecord(
            decision,
            None if observation is None else action.observation.name(observation),
            probability,
            float(belief.max()),
            names.name(robot.state),
            chooser.new_plan,
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
    record.pose = None if model.grid is None else belief_pose(model, belief)
    record.plan_seconds = list(chooser.plan_seconds)
    record.replans = chooser.replans
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
    shared = SharedWork.for_model(model)
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
                shared=shared,
                max_steps=max_steps,
                on_step=on_step,
            )
            records.append(record)
            if on_episode is not None:
                on_episode(record)
    return records


@dataclass(frozen=True)
class StrategySummary:
    """One strategy's episodes in numbers (the paper's Tables I and II)."""

    episodes: int
    localized: int
    correct: int
    """Localized episodes whose most likely state at the end is the robot's true state (never more
    than ``localized``)."""
    failures: dict[str, int]
    """Episodes per status other than localized, by the status's name."""
    mean_plan_seconds: float | None
    """Table I's metric: per episode the mean over its plan calls, then the mean over episodes."""
    stdev_plan_seconds: float | None
    mean_replans: float | None
    mean_cost: float | None
    """Over the localized episodes."""
    stdev_cost: float | None
    mean_steps: float | None
    """Over the localized episodes."""

    def as_json(self, *, timings: bool = True) -> dict[str, Any]:
        data = asdict(self)
        if not timings:
            data.update({key: None for key in data if "seconds" in key})
        return data


def summarize(records: Sequence[EpisodeRecord]) -> dict[str, StrategySummary]:
    """Per strategy, in the order the records name them: see :class:`StrategySummary`."""
    out: dict[str, StrategySummary] = {}
    for name in dict.fromkeys(r.strategy for r in records):
        mine = [r for r in records if r.strategy == name]
        localized = [r for r in mine if r.status is EpisodeStatus.LOCALIZED]
        per_episode_plan = [statistics.fmean(r.plan_seconds) for r in mine if r.plan_seconds]
        failed = sorted({r.status.value for r in mine if r.status is not EpisodeStatus.LOCALIZED})
        out[name] = StrategySummary(
            episodes=len(mine),
            localized=len(localized),
            correct=sum(r.correct for r in localized),
            failures={s: sum(r.status.value == s for r in mine) for s in failed},
            mean_plan_seconds=_mean(per_episode_plan),
            stdev_plan_seconds=_stdev(per_episode_plan),
            mean_replans=_mean([r.replans for r in mine]),
            mean_cost=_mean([r.cost for r in localized]),
            stdev_cost=_stdev([r.cost for r in localized]),
            mean_steps=_mean([r.steps for r in localized]),
        )
    return out


def _mean(values: Sequence[float]) -> float | None:
    return statistics.fmean(values) if values else None


def _stdev(values: Sequence[float]) -> float | None:
    return statistics.stdev(values) if len(values) > 1 else None
