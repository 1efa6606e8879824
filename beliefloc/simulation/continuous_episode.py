"""Episodes against a continuous simulated robot (``simulate --continuous``, issue 26).

The grid episode (:func:`beliefloc.simulation.episode.run_episode`) samples the robot from the
planner's own model: it can never show what the model leaves out. Here the robot is a
:class:`~beliefloc.continuous.world.ContinuousRobot`: a true pose anywhere in free space (where its
disc fits) with any yaw, noisy motion stopped where the map blocks it, ray-cast Scan ranges with
range noise and optional clutter (a share of beams reading a random range), Look detections by field
of view, range and line of sight. It answers through
:class:`~beliefloc.robots.continuous_robot.ContinuousReadingRobot` -- the robot interface the line
protocol uses -- and the episode is ``localize``'s loop (:func:`beliefloc.robots.localize.localize`:
odometry and blocked flag in the replies, the surprise check, re-spread and ``inconsistent``) with
any of ``simulate``'s strategies choosing the actions.

Each record carries :class:`~beliefloc.simulation.episode.ContinuousOutcome`: the start and final
true poses, the position and yaw error of the reported state, and whether the episode was
*confidently wrong*: declared localized with the true pose more than
:data:`WRONG_CELLS` cells from the reported state's centre or more than one heading sector from its
heading.

Random numbers: the start pose from the episode's start generator, the world's noise from its world
generator, the strategy's from its own (:func:`beliefloc.simulation.episode.episode_rngs`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from beliefloc.continuous.world import Clutter, ContinuousRobot, ContinuousWorld, LaserSpec, MotionError, WorldConfig
from beliefloc.errors import InvalidValueError
from beliefloc.model import GridLayout, Model, wrap_angle
from beliefloc.pose import Pose, state_pose
from beliefloc.robots.belief_filter import LatticeFilter
from beliefloc.robots.continuous_robot import ContinuousReadingRobot
from beliefloc.robots.localize import LocalizeStep, localize
from beliefloc.robots.readings import ReadingBinner
from beliefloc.semantic_map import regions
from beliefloc.semantic_map.lattice_sensors import robot_radius
from beliefloc.semantic_map.schema import SemanticMap
from beliefloc.simulation.episode import ContinuousOutcome, EpisodeRecord, OnStep, StepRecord, episode_rngs
from beliefloc.simulation.settings import MAX_OBSTACLES, StrategyName
from beliefloc.simulation.strategies import EpisodeStatus, PlannerSettings, SharedWork, Strategy, make_strategy

WRONG_CELLS = 1.5
"""An episode declared localized is wrong when the true pose is more than this many cells from the
reported state's centre (or more than one heading sector from its heading): issue 26's measure. The
lattice filter declares a state with the probability of a reach inside this promise
(:data:`beliefloc.continuous.pose_lattice.PROMISE_CELLS`, the same 1.5), so its declared probability
bounds the chance of a right declaration from below."""
MOVES_STREAM = 26
"""The third key of the generator of the moves ``localize`` makes instead of a repeated reading."""


@dataclass(frozen=True)
class ContinuousSetup:
    """The continuous world of ``simulate --continuous``: the map and the noise of the robot."""

    smap: SemanticMap
    clutter: float = 0.0
    """Share of Scan beams that read a uniformly random range instead of the true one."""
    obstacles: int = 0
    """Unmapped obstacles: discs of 0.1-0.3 m radius (people, boxes, a chair) placed anywhere in free space
    afresh each episode, their centres at least half a metre from the start; rays stop on them and so does the
    robot, and the map does not show them."""
    translation_noise: float = 0.05
    """Standard deviation of a move's length error, relative (0.05: 5 % of the distance)."""
    turn_noise: float = math.radians(2.0)
    """Radians: standard deviation of the yaw error of every command that turns."""
    range_noise: float = 0.02
    """Metres: standard deviation of a range reading's error."""
    range_max: float = 12.0
    confirm: bool = True
    """``localize``'s confirmation: a belief at the threshold is declared only if it still holds it
    after a move and a reading from where the robot lands."""
    report_odometry: bool = True
    """Replies carry the wheels' odometry and the blocked flag (False: protocol 1, readings only)."""
    full_scans: int = 0
    """Scan sensors answer a whole scan of this many beams around the robot (a 2-D lidar's; the
    lattice filter scores it in full); 0: the map's beams only."""
    lattice: bool = True
    """``localize`` keeps its belief over a pose lattice finer than the states
    (:class:`~beliefloc.robots.belief_filter.LatticeFilter`: the filter for a real robot); False:
    over the model's states (``T_a``, ``O_a``)."""
    mean_reach: bool = False
    """The lattice filter declares by the reach around the belief's mean pose too
    (:attr:`beliefloc.continuous.pose_lattice.LatticeFilter.mean_reach_too`)."""
    _cache: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.clutter) and 0.0 <= self.clutter < 1.0):
            raise InvalidValueError(f"clutter: {self.clutter!r} is not a fraction from 0 up to (not including) 1")
        for name in ("translation_noise", "turn_noise", "range_noise"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 <= value <= 1.0):
                raise InvalidValueError(f"{name}: {value!r} is not a number from 0 to 1")
        whole = isinstance(self.obstacles, int) and not isinstance(self.obstacles, bool)
        if not (whole and 0 <= self.obstacles <= MAX_OBSTACLES):
            raise InvalidValueError(f"obstacles: {self.obstacles!r} is not a whole number from 0 to {MAX_OBSTACLES}")
        if self.smap.grid is None:
            raise InvalidValueError(f"map {self.smap.name!r}: a continuous robot needs a map with a grid")

    def __getstate__(self) -> dict[str, Any]:  # the cache is rebuilt by each worker
        state = dict(self.__dict__)
        state["_cache"] = {}
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

    @property
    def config(self) -> WorldConfig:
        return WorldConfig(
            laser=LaserSpec(range_sd=self.range_noise, range_max=self.range_max, range_min=0.01, mount=(0.0, 0.0, 0.0)),
            motion_error=MotionError(
                translation=self.translation_noise, rotation=0.0, per_turn=self.turn_noise, per_metre=0.0
            ),
            clutter=Clutter(count=self.obstacles, spurious=self.clutter),
            robot_radius=robot_radius(self.smap),
        )

    def world(self, rng: np.random.Generator) -> ContinuousWorld:
        """The world (built once per process: its clearance map is the slow part), drawing from ``rng``."""
        world = self._cache.get("world")
        if world is None:
            world = world_of(self.smap, self.config, rng)
            self._cache["world"] = world
        world.rng = rng
        return world

    def binner(self, model: Model) -> ReadingBinner:
        binner = self._cache.get("binner")
        if binner is None or binner.model is not model:
            binner = ReadingBinner(self.smap, model)
            self._cache["binner"] = binner
        return binner

    def belief_filter(self, model: Model) -> LatticeFilter | None:
        """The lattice filter for ``model`` (built once per process), or None with ``lattice`` off."""
        if not self.lattice:
            return None
        built = self._cache.get("lattice")
        if built is None or built.model is not model:
            built = LatticeFilter(self.binner(model), mean_reach=self.mean_reach)
            self._cache["lattice"] = built
        return built

    def robot(
        self, model: Model, seed: int, episode: int
    ) -> tuple[ContinuousRobot, ContinuousReadingRobot, np.random.Generator]:
        """Episode ``episode``'s robot at its start pose, the robot interface the loop talks to, and the
        strategy's generator: the same episode's robot draws the same noise for the same actions, so
        an episode's actions replayed (``benchmarks/bench_offgrid.py --replay``) give its readings again."""
        start_rng, world_rng, strategy_rng = episode_rngs(seed, episode)
        start = self.world(start_rng).random_poses(1)[0]
        world = self.world(world_rng)
        if self.obstacles:  # this episode's own, drawn before the robot's noise (none drawn without them)
            world.place_clutter(keep_clear=[(float(start[0]), float(start[1]))])
        robot = ContinuousRobot(world, start)
        reading = ContinuousReadingRobot(
            robot,
            self.smap,
            self.binner(model),
            report_odometry=self.report_odometry,
            report_blocked=self.report_odometry,
            full_scans=self.full_scans,
        )
        return robot, reading, strategy_rng

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
    ) -> EpisodeRecord:
        """One episode of ``strategy`` against the continuous robot (see the module)."""
        grid = model.grid
        if grid is None:
            raise InvalidValueError(f"model {model.name!r} has no grid: a continuous robot cannot stand on it")
        robot, reading, strategy_rng = self.robot(model, seed, episode)
        start = robot.pose.copy()
        binner = self.binner(model)
        name = StrategyName(strategy)

        def make(planner: PlannerSettings) -> Strategy:  # the loop's planning goal (planning_goal)
            return make_strategy(name, planner, shared, strategy_rng)

        record = EpisodeRecord(
            name.value, episode, _state_name(model, start), "", "", False, EpisodeStatus.LOCALIZED, 0.0, 0, 0, [], 0.0
        )

        def step(done: LocalizeStep) -> None:
            record.steps += 1
            action = done.command.action
            observation = None if done.observation is None else action.observation.name(done.observation)
            true_state = _state_name(model, robot.pose)
            record.trace.append(
                StepRecord(
                    action.name, observation, done.probability, float(done.belief.max()), true_state, done.command.plan
                )
            )
            if on_step is not None:
                on_step(record, record.trace[-1], done.belief)

        outcome = localize(
            model,
            start_belief,
            reading,
            binner,
            settings=settings,
            max_steps=max_steps,
            on_step=step,
            strategy=make,
            rng=np.random.default_rng([seed, episode, MOVES_STREAM]),
            confirm=self.confirm,
            belief_filter=self.belief_filter(model),
        )
        state, probability = outcome.declared
        true_state = state_at(grid, robot.pose)
        record.final = model.states.name(state)
        record.true_final = _state_name(model, robot.pose)
        record.correct = state == true_state
        record.status = outcome.status
        record.cost = outcome.cost
        record.steps = outcome.steps
        record.replans = outcome.replans
        record.plan_seconds = list(outcome.plan_seconds)
        record.max_belief = probability
        estimate = outcome.pose_estimate(model)
        assert estimate is not None  # the model has a grid
        record.pose = estimate
        position_error, yaw_error = pose_errors(grid, state, robot.pose)
        off, turned = reported_errors(grid, estimate.pose, robot.pose)
        record.continuous = ContinuousOutcome(
            start_pose=_triple(start),
            true_pose=_triple(robot.pose),
            position_error=position_error,
            yaw_error=yaw_error,
            confidently_wrong=outcome.localized and is_wrong(grid, position_error, yaw_error),
            model_confidence=outcome.model_confidence,
            recoveries=outcome.recoveries,
            pose_position_error=off,
            pose_yaw_error=turned,
        )
        return record


def world_of(smap: SemanticMap, config: WorldConfig, rng: np.random.Generator) -> ContinuousWorld:
    """The continuous world of ``smap``: its occupancy image, or for a hand-drawn grid the image of
    its blocked cells (one pixel a cell, the grid's frame)."""
    occupancy = smap.occupancy_map
    if occupancy is not None:
        return ContinuousWorld(occupancy, config, rng)
    return ContinuousWorld(regions.blocked_image(~smap.free, smap.grid.cell_size), config, rng)


def heading_of(grid: GridLayout, yaw: float) -> int:
    """The heading sector holding map-frame ``yaw`` (0 with one heading)."""
    if grid.headings == 1:
        return 0
    step = 2 * math.pi / grid.headings
    return round((grid.frame.yaw + math.pi / 2 - yaw) / step) % grid.headings


def state_at(grid: GridLayout, pose: np.ndarray) -> int:
    """The state whose region holds the continuous ``pose`` (x, y, yaw); -1 when its cell is no state."""
    row, col = grid.cell_at(float(pose[0]), float(pose[1]))
    return grid.state_of(int(row), int(col), heading_of(grid, float(pose[2])))


def pose_errors(grid: GridLayout, state: int, pose: np.ndarray) -> tuple[float, float]:
    """Metres from state ``state``'s cell centre to ``pose``, and radians from its heading's yaw
    (0 with one heading: the yaw is not estimated)."""
    return reported_errors(grid, state_pose(grid, state), pose)


def reported_errors(grid: GridLayout, reported: Pose, pose: np.ndarray) -> tuple[float, float]:
    """Metres from the ``reported`` pose to ``pose``, and radians between their yaws (0 with one
    heading: the yaw is not estimated)."""
    position = math.hypot(reported.x - float(pose[0]), reported.y - float(pose[1]))
    if grid.headings == 1:
        return position, 0.0
    return position, abs(float(wrap_angle(reported.yaw - float(pose[2]))))


def is_wrong(grid: GridLayout, position_error: float, yaw_error: float) -> bool:
    """More than :data:`WRONG_CELLS` cells or one heading sector from the reported state."""
    sector = 2 * math.pi / grid.headings if grid.headings > 1 else math.inf
    return position_error > WRONG_CELLS * grid.cell_size or yaw_error > sector


def _state_name(model: Model, pose: np.ndarray) -> str:
    """The name of the state holding ``pose``; ``"-"`` when the robot stands where no state is."""
    assert model.grid is not None
    state = state_at(model.grid, pose)
    return "-" if state < 0 else model.states.name(state)


def _triple(pose: np.ndarray) -> tuple[float, float, float]:
    x, y, yaw = (float(v) for v in pose)
    return (x, y, yaw)
