"""Episodes and paired experiments: every strategy runs on the same seeded starts and noise.

An episode: the robot starts in a true state unknown to it; from the start belief the strategy
chooses an action, the simulated robot executes it and reports an observation, the belief is
updated, and so on until ``max(b) >= threshold`` (localized), the strategy gives up (no plan,
budget exceeded), or a step limit. Records are plain data; statistics are computed from them.
"""

from __future__ import annotations

import math
import statistics
from array import array
from collections.abc import Callable, Iterable, Iterator, Sequence
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
from beliefloc.source.record_fields import flag_field, number_field, text_field, whole_field


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
    pose_position_error: float | None = None
    """Metres from the reported pose (the record's ``pose``: finer than the state's centre where the
    filter knows it, the pose lattice's) to the true position; None in records made before it."""
    pose_yaw_error: float | None = None
    """Radians from the reported pose's yaw to the true yaw (0 with one heading)."""

    def as_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "start_pose": list(self.start_pose),
            "true_pose": list(self.true_pose),
            "position_error": self.position_error,
            "yaw_error": self.yaw_error,
            "confidently_wrong": self.confidently_wrong,
            "model_confidence": self.model_confidence,
            "recoveries": self.recoveries,
        }
        if self.pose_position_error is not None and self.pose_yaw_error is not None:
            out["pose_position_error"] = self.pose_position_error
            out["pose_yaw_error"] = self.pose_yaw_error
        return out

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
        optional = ("pose_position_error", "pose_yaw_error")  # both or neither
        extra = sorted(set(data) - set(fields) - set(optional))
        if extra:
            raise ValueError(f"continuous: unknown field {extra[0][:40]!r}")
        missing = [k for k in fields if k not in data]
        if missing:
            raise ValueError(f"continuous: no field {missing[0]!r}")
        if (optional[0] in data) != (optional[1] in data):
            raise ValueError(f"continuous: {optional[0]!r} and {optional[1]!r} come together")
        poses = []
        for key in ("start_pose", "true_pose"):
            value = data[key]
            if not isinstance(value, list) or len(value) != 3:
                raise ValueError(f"continuous.{key}: {str(value)[:40]!r} is not a list [x, y, yaw]")
            x, y, yaw = (number_field({f"continuous.{key}": v}, f"continuous.{key}") for v in value)
            poses.append((x, y, yaw))
        present = [k for k in ("position_error", "yaw_error", *optional) if k in data]
        errors = {k: number_field({f"continuous.{k}": data[k]}, f"continuous.{k}") for k in present}
        for key, value in errors.items():
            if key.endswith("position_error") and value < 0:
                raise ValueError(f"continuous.{key}: {value!r} is not a distance >= 0")
            if key.endswith("yaw_error") and not 0 <= value <= math.pi + 1e-9:
                raise ValueError(f"continuous.{key}: {value!r} is not an angle from 0 to pi")
        confidence = number_field(
            {"continuous.model_confidence": data["model_confidence"]}, "continuous.model_confidence"
        )
        if not 0.0 <= confidence <= 1.0:
            raise ValueError(f"continuous.model_confidence: {confidence!r} is not in [0, 1]")
        return cls(
            start_pose=poses[0],
            true_pose=poses[1],
            position_error=errors["position_error"],
            yaw_error=errors["yaw_error"],
            confidently_wrong=flag_field(
                {"continuous.confidently_wrong": data["confidently_wrong"]}, "continuous.confidently_wrong"
            ),
            model_confidence=confidence,
            recoveries=whole_field({"continuous.recoveries": data["recoveries"]}, "continuous.recoveries"),
            pose_position_error=errors.get("pose_position_error"),
            pose_yaw_error=errors.get("pose_yaw_error"),
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
            strategy=text_field(data, "strategy"),
            episode=whole_field(data, "episode"),
            start=text_field(data, "start"),
            final=text_field(data, "final"),
            true_final=text_field(data, "true_final"),
            correct=flag_field(data, "correct"),
            status=EpisodeStatus(text_field(data, "status")),
            cost=number_field(data, "cost"),
            steps=whole_field(data, "steps"),
            replans=whole_field(data, "replans"),
            plan_seconds=[number_field({"plan_seconds": x}, "plan_seconds") for x in seconds or []],
            max_belief=number_field(data, "max_belief"),
            continuous=ContinuousOutcome.from_json(data["continuous"]) if "continuous" in data else None,
        )


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
            else:
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


def records_from_results(results: Iterable[dict[str, Any]]) -> list[EpisodeRecord]:
    """The records of :class:`EpisodeSweep` results, in order (:meth:`EpisodeRecord.from_json`)."""
    return [record for result in results for record in records_of_result(result)]


def records_of_result(result: dict[str, Any]) -> Iterator[EpisodeRecord]:
    """The records of one :class:`EpisodeSweep` result (a line of a results file), one per strategy."""
    records = result["records"]
    if not isinstance(records, list) or not records:
        raise ValueError(f"records: {str(records)[:40]!r} is not a list of episode records")
    return (EpisodeRecord.from_json(data) for data in records)


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


def summarize(records: Iterable[EpisodeRecord]) -> dict[str, StrategySummary]:
    """Per strategy, in the order the records name them: see :class:`StrategySummary`. One pass,
    keeping only the numbers the statistics need (8 bytes each): ``summarize`` of a results file of
    millions of episodes streams its records through here."""
    tallies: dict[str, _Tally] = {}
    for record in records:
        tally = tallies.get(record.strategy)
        if tally is None:
            tally = tallies[record.strategy] = _Tally()
        tally.add(record)
    return {name: tally.summary() for name, tally in tallies.items()}


class _Tally:
    """One strategy's episodes so far, as counts and columns of numbers."""

    def __init__(self) -> None:
        self.episodes = self.localized = self.correct = 0
        self.failures: dict[str, int] = {}
        self.plan = array("d")
        """Per episode with plan calls, the mean of their seconds."""
        self.replans = array("d")
        self.cost = array("d")
        """Of the localized episodes, as are the steps."""
        self.steps = array("d")

    def add(self, r: EpisodeRecord) -> None:
        self.episodes += 1
        if r.plan_seconds:
            self.plan.append(statistics.fmean(r.plan_seconds))
        self.replans.append(r.replans)
        if r.status is EpisodeStatus.LOCALIZED:
            self.localized += 1
            self.correct += r.correct
            self.cost.append(r.cost)
            self.steps.append(r.steps)
        else:
            self.failures[r.status.value] = self.failures.get(r.status.value, 0) + 1

    def summary(self) -> StrategySummary:
        return StrategySummary(
            episodes=self.episodes,
            localized=self.localized,
            correct=self.correct,
            failures={s: self.failures[s] for s in sorted(self.failures)},
            mean_plan_seconds=_mean(self.plan),
            stdev_plan_seconds=_stdev(self.plan),
            mean_replans=_mean(self.replans),
            mean_cost=_mean(self.cost),
            stdev_cost=_stdev(self.cost),
            mean_steps=_mean(self.steps),
        )


def _mean(values: Sequence[float]) -> float | None:
    return statistics.fmean(values) if values else None


def _stdev(values: Sequence[float]) -> float | None:
    return statistics.stdev(values) if len(values) > 1 else None
