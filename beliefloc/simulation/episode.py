"""Episodes and paired experiments: every strategy runs on the same seeded starts and noise.

An episode: the robot starts in a true state unknown to it; from the start belief the strategy
chooses an action, the simulated robot executes it and reports an observation, the belief is
updated, and so on until ``max(b) >= threshold`` (localized), the strategy gives up (no plan,
budget exceeded), or a step limit. Records are plain data; statistics are computed from them.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

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


@dataclass(frozen=True)
class ContinuousOutcome:
    """How an episode against a continuous robot ended (``simulate --continuous``,
    :mod:`beliefloc.simulation.continuous_episode`): where the robot truly was, and how far the
    reported state (the most likely one) is from it."""

    start_pose: tuple[float, float, float]
    """The true start pose ``(x, y, yaw)``: map-frame metres and radians."""
    true_pose: tuple[float, float, float]
    """The true pose at the end."""
    position_error: float
    """Metres from the reported state's cell centre to the true position."""
    yaw_error: float
    """Radians from the reported state's heading to the true yaw (0 with one heading)."""
    confidently_wrong: bool
    """Declared localized, yet the true pose is more than 1.5 cells or one heading sector from the
    reported state: the worst outcome there is."""
    model_confidence: float
    """How well the last readings fit the belief, in [0, 1] (``localize``'s)."""
    recoveries: int
    """How many times the readings stopped fitting and the belief was re-spread."""

    def as_json(self) -> dict[str, Any]:
        return {
            "start_pose": list(self.start_pose),
            "true_pose": list(self.true_pose),
            "position_error": self.position_error,
            "yaw_error": self.yaw_error,
            "confidently_wrong": self.confidently_wrong,
            "model_confidence": self.model_confidence,
            "recoveries": self.recoveries,
        }

    @classmethod
    def from_json(cls, data: object) -> ContinuousOutcome:
        """Strictly: every field there, of its type, finite; nothing else."""
        if not isinstance(data, dict):
            raise ValueError(f"continuous: {str(data)[:40]!r} is not an object")
        fields = (
            "start_pose",
            "true_pose",
            "position_error",
            "yaw_error",
            "confidently_wrong",
            "model_confidence",
            "recoveries",
        )
        extra = sorted(set(data) - set(fields))
        if extra:
            raise ValueError(f"continuous: unknown field {extra[0][:40]!r}")
        poses = []
        for key in ("start_pose", "true_pose"):
            value = data[key]
            if not isinstance(value, list) or len(value) != 3:
                raise ValueError(f"continuous.{key}: {str(value)[:40]!r} is not a list [x, y, yaw]")
            x, y, yaw = (_number({f"continuous.{key}": v}, f"continuous.{key}") for v in value)
            poses.append((x, y, yaw))
        errors = [_number({f"continuous.{k}": data[k]}, f"continuous.{k}") for k in ("position_error", "yaw_error")]
        if errors[0] < 0:
            raise ValueError(f"continuous.position_error: {errors[0]!r} is not a distance >= 0")
        if not 0 <= errors[1] <= math.pi + 1e-9:
            raise ValueError(f"continuous.yaw_error: {errors[1]!r} is not an angle from 0 to pi")
        confidence = _number({"continuous.model_confidence": data["model_confidence"]}, "continuous.model_confidence")
        if not 0.0 <= confidence <= 1.0:
            raise ValueError(f"continuous.model_confidence: {confidence!r} is not in [0, 1]")
        return cls(
            start_pose=poses[0],
            true_pose=poses[1],
            position_error=errors[0],
            yaw_error=errors[1],
            confidently_wrong=_flag(
                {"continuous.confidently_wrong": data["confidently_wrong"]}, "continuous.confidently_wrong"
            ),
            model_confidence=confidence,
            recoveries=_whole({"continuous.recoveries": data["recoveries"]}, "continuous.recoveries"),
        )


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
    continuous: ContinuousOutcome | None = None
    """An episode against a continuous robot: its true poses and errors (None on the grid; then
    :attr:`start` and :attr:`true_final` name the states holding the true poses, ``"-"`` where none does)."""

    def as_json(self, *, timings: bool = True) -> dict[str, Any]:
        """What ``simulate --json`` prints per episode; without ``timings`` no clock value.
        ``"pose"`` is :meth:`PoseEstimate.as_json` of the final belief (null without a grid);
        ``"continuous"`` (:meth:`ContinuousOutcome.as_json`) only for an episode against a continuous robot."""
        data = asdict(self)
        data.pop("trace")
        data.pop("continuous")
        data["status"] = self.status.value
        data["pose"] = None if self.pose is None else self.pose.as_json()
        if self.continuous is not None:
            data["continuous"] = self.continuous.as_json()
        if not timings:
            data["plan_seconds"] = None
        return data

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> EpisodeRecord:
        """The record :meth:`as_json` gave ``data``, for statistics (:func:`summarize`): without its
        trace and its ``pose`` (a pose needs the model), and with ``plan_seconds`` empty when the
        JSON has no clock values."""
        seconds = data["plan_seconds"]
        if seconds is not None and not isinstance(seconds, list):
            raise ValueError(f"plan_seconds: {seconds!r} is not a list of numbers")
        return cls(
            strategy=_text(data, "strategy"),
            episode=_whole(data, "episode"),
            start=_text(data, "start"),
            final=_text(data, "final"),
            true_final=_text(data, "true_final"),
            correct=_flag(data, "correct"),
            status=EpisodeStatus(_text(data, "status")),
            cost=_number(data, "cost"),
            steps=_whole(data, "steps"),
            replans=_whole(data, "replans"),
            plan_seconds=[_number({"plan_seconds": x}, "plan_seconds") for x in seconds or []],
            max_belief=_number(data, "max_belief"),
            continuous=ContinuousOutcome.from_json(data["continuous"]) if "continuous" in data else None,
        )


def _text(data: dict[str, Any], key: str) -> str:
    """A string field of a record read back from a file: a number or a list is no name."""
    value = data[key]
    if not isinstance(value, str):
        raise ValueError(f"{key}: {value!r} is not a string")
    return value


def _whole(data: dict[str, Any], key: str) -> int:
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 2**62:
        raise ValueError(f"{key}: {str(value)[:40]!r} is not a whole number from 0 to 2**62")
    return value


def _number(data: dict[str, Any], key: str) -> float:
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{key}: {str(value)[:40]!r} is not a number")
    number = float(value)  # an int of 400 digits: OverflowError, caught by the reader
    if number != number or number in (float("inf"), float("-inf")):
        raise ValueError(f"{key}: {value!r} is not a finite number")
    return number


def _flag(data: dict[str, Any], key: str) -> bool:
    value = data[key]
    if not isinstance(value, bool):
        raise ValueError(f"{key}: {value!r} is not true or false")
    return value


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


def start_state(
    model: Model, seed: int, episode: int, *, start: int | None = None, start_distribution: np.ndarray | None = None
) -> int:
    """The robot's true start in episode ``episode``: ``start`` when given, else drawn from the
    episode's start generator (:func:`episode_rngs`) -- from ``start_distribution`` (a probability
    per state) when given, else uniformly."""
    if start is not None:
        return start
    start_rng, _, _ = episode_rngs(seed, episode)
    if start_distribution is not None:
        return int(start_rng.choice(model.n_states, p=start_distribution))
    return int(start_rng.integers(model.n_states))


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
    sweep = EpisodeSweep(
        model,
        tuple(strategies),
        seed=seed,
        start=start,
        start_belief=start_belief,
        start_distribution=start_distribution,
        world=world,
        settings=settings,
        max_steps=max_steps,
    )
    shared = SharedWork.for_model(model)
    records = []
    for e in range(episodes):
        records += sweep.paired(e, shared, on_step=on_step, on_episode=on_episode)
    return records


class EpisodeRunner(Protocol):
    """Runs one episode against a robot of its own instead of the model's simulated one
    (:class:`beliefloc.simulation.continuous_episode.ContinuousSetup`: ``simulate --continuous``)."""

    def run(
        self,
        model: Model,
        strategy: str,
        *,
        seed: int,
        episode: int,
        start_belief: np.ndarray,
        settings: PlannerSettings,
        shared: SharedWork,
        max_steps: int,
        on_step: OnStep | None = None,
    ) -> EpisodeRecord: ...


@dataclass(frozen=True)
class EpisodeSweep:
    """Paired episodes as a sweep (:mod:`beliefloc.simulation.sweep`): unit ``e`` is episode ``e`` of every
    strategy, its result ``{"episode": e, "records": [EpisodeRecord.as_json(), ...]}`` in the order of
    ``strategies``. Episode ``e`` depends on (``seed``, ``e``) only (:func:`episode_rngs`), so any
    worker may run it, in any order, with the same result."""

    model: Model
    strategies: tuple[str, ...]
    seed: int
    start: int | None = None
    start_belief: np.ndarray | None = None
    start_distribution: np.ndarray | None = None
    world: Model | None = None
    settings: PlannerSettings | None = None
    max_steps: int = DEFAULT_MAX_STEPS
    timings: bool = True
    """Keep the wall-clock values in the results (off: byte-identical reruns)."""
    robot: EpisodeRunner | None = None
    """Episodes against this robot (a continuous one) instead of one sampled from the model; the
    start is then the runner's (``start`` and ``start_distribution`` are not used)."""

    def paired(
        self,
        episode: int,
        shared: SharedWork,
        *,
        on_step: OnStep | None = None,
        on_episode: Callable[[EpisodeRecord], None] | None = None,
    ) -> list[EpisodeRecord]:
        """Episode ``episode`` of every strategy, from the same true start."""
        model = self.model
        belief = self.start_belief if self.start_belief is not None else np.full(model.n_states, 1.0 / model.n_states)
        state = start_state(model, self.seed, episode, start=self.start, start_distribution=self.start_distribution)
        records = []
        for name in self.strategies:
            if self.robot is not None:
                record = self.robot.run(
                    model,
                    name,
                    seed=self.seed,
                    episode=episode,
                    start_belief=belief,
                    settings=self.settings or PlannerSettings(),
                    shared=shared,
                    max_steps=self.max_steps,
                    on_step=on_step,
                )
                records.append(record)
                if on_episode is not None:
                    on_episode(record)
                continue
            record = run_episode(
                model,
                name,
                state,
                belief,
                seed=self.seed,
                episode=episode,
                world=self.world,
                settings=self.settings,
                shared=shared,
                max_steps=self.max_steps,
                on_step=on_step,
            )
            records.append(record)
            if on_episode is not None:
                on_episode(record)
        return records

    def runner(
        self, *, on_step: OnStep | None = None, on_episode: Callable[[EpisodeRecord], None] | None = None
    ) -> Callable[[int], dict[str, Any]]:
        """The work shared by a worker's episodes (:class:`SharedWork`), and the runner of one episode;
        with per-step and per-episode callbacks for a run in this process that draws or records."""
        shared = SharedWork.for_model(self.model)

        def run(episode: int) -> dict[str, Any]:
            records = self.paired(episode, shared, on_step=on_step, on_episode=on_episode)
            return {"episode": episode, "records": [r.as_json(timings=self.timings) for r in records]}

        return run


def records_from_results(results: Sequence[dict[str, Any]]) -> list[EpisodeRecord]:
    """The records of :class:`EpisodeSweep` results, in order (:meth:`EpisodeRecord.from_json`)."""
    out: list[EpisodeRecord] = []
    for result in results:
        records = result["records"]
        if not isinstance(records, list) or not records:
            raise ValueError(f"records: {str(records)[:40]!r} is not a list of episode records")
        out.extend(EpisodeRecord.from_json(data) for data in records)
    return out


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
