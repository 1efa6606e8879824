"""A continuous simulated robot world: a true pose anywhere in free space with any yaw, noisy
motion, drifting odometry, and laser scans ray-cast on the occupancy image plus unmapped clutter.

The world is the *truth*, kept apart from any model of it (POMDPs.jl's simulator vs. belief
updater): it has its own seeded :class:`numpy.random.Generator`, its own noise, and obstacles the map
does not hold. Two ways to use it:

- step by step, as a robot: :class:`ContinuousRobot` (``pose``, :meth:`~ContinuousRobot.drive`,
  :meth:`~ContinuousRobot.scan`) -- what a simulated robot speaking a line protocol wraps;
- a whole timed run, as a recording: :func:`simulate_run` follows a :class:`Segment` plan and returns
  a :class:`Run` (odometry at its rate, scans at theirs, stamps not aligned, per-beam timing while
  turning, the true pose at every stamp) -- what the bag writer turns into test recordings.

Frames (REP 103/105): ``map`` (the occupancy image's frame), ``odom`` (where the wheels think the
robot is: starts at the robot's pose's identity and drifts away from the truth), ``base_link`` (the
robot), and the laser's frame, mounted at :attr:`LaserSpec.mount` ``(x, y, yaw)`` in ``base_link``.

Pure numpy/scipy, no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.motion import compose, relative
from beliefloc.continuous.raycast import cast_rays, ray_disc_distances
from beliefloc.model import wrap_angle
from beliefloc.semantic_map.occupancy_map import Occupancy, OccupancyMap


@dataclass(frozen=True)
class LaserSpec:
    """A planar laser as ``sensor_msgs/LaserScan`` describes it, and how it is mounted.

    Defaults: the RPLIDAR of a TurtleBot4 (720 beams from -3.124 to +3.1416 rad, 0.15..12 m, a
    sweep of ~0.13 s), mounted rotated +90° about z at the base's centre."""

    beams: int = 720
    angle_min: float = -3.124
    """Radians, the first beam's angle in the laser frame."""
    angle_max: float = 3.1416
    """Radians, the last beam's angle (``angle_increment = (angle_max - angle_min) / (beams - 1)``)."""
    range_min: float = 0.15
    """Metres: nearer returns read ``-inf`` (REP 117: too close)."""
    range_max: float = 12.0
    """Metres: nothing within this reads ``+inf`` (REP 117: no return)."""
    scan_time: float = 0.13
    """Seconds for one sweep; beam ``b`` is measured at ``stamp + b * time_increment``."""
    range_sd: float = 0.01
    """Metres: Gaussian range noise of a return."""
    mount: tuple[float, float, float] = (0.0, 0.0, math.pi / 2)
    """``(x, y, yaw)`` of the laser frame in ``base_link`` (REP 103)."""

    def __post_init__(self) -> None:
        if self.beams < 2:
            raise ValueError(f"LaserSpec.beams must be at least 2, got {self.beams}")
        if not (0 < self.range_min < self.range_max < math.inf):
            raise ValueError(f"LaserSpec needs 0 < range_min < range_max < inf, got {self.range_min}, {self.range_max}")

    @property
    def angle_increment(self) -> float:
        return (self.angle_max - self.angle_min) / (self.beams - 1)

    @property
    def time_increment(self) -> float:
        return self.scan_time / self.beams

    @property
    def angles(self) -> np.ndarray:
        """Beam angles in the laser frame, shape ``(beams,)``."""
        return self.angle_min + self.angle_increment * np.arange(self.beams)


@dataclass(frozen=True)
class Clutter:
    """Unmapped obstacles: discs (people, chair legs, tables' feet) in free space the map does not show,
    and spurious returns (dust, glass)."""

    count: int = 0
    """How many discs."""
    radius: tuple[float, float] = (0.1, 0.3)
    """Metres: each disc's radius is uniform in this range."""
    spurious: float = 0.0
    """Probability that a beam reads a random range in ``[range_min, range_max)`` instead."""
    dropout: float = 0.0
    """Probability that a beam that hit something reads ``+inf`` anyway (a dark or glancing surface)."""
    keep_clear: float = 0.5
    """Metres: no disc's centre within this of the robot's start (nor so near that the largest disc
    would touch the robot there: a disc never stands where the robot does)."""


@dataclass(frozen=True)
class Drift:
    """How the wheel odometry departs from the true motion, on top of its random noise."""

    scale: float = 0.0
    """Relative error of the measured translation (0.02: the wheels report 2 % more than driven)."""
    yaw_rate: float = 0.0
    """Radians of yaw error per metre driven (a wheel-diameter mismatch)."""
    turn_scale: float = 0.0
    """Relative error of the measured rotation."""


@dataclass(frozen=True)
class MotionError:
    """How the true motion departs from a commanded one: zero-mean Gaussian errors, drawn once per
    :meth:`ContinuousRobot.drive` (per segment in :func:`simulate_run`), proportional to the motion.

    Componentwise on ``(dx, dy, dyaw)`` rather than Table 5.6's three parts, so that a turn in place
    never moves the base and many small steps are not biased (Table 5.6 maps a tiny translation's
    direction onto the heading)."""

    translation: float = 0.05
    """Standard deviation of the relative translation error (0.05: 5 % of the distance)."""
    rotation: float = 0.02
    """Standard deviation of the relative rotation error (of the angle turned)."""
    per_turn: float = math.radians(2.0)
    """Radians: standard deviation of an extra yaw error of every command that turns."""
    per_metre: float = 0.02
    """Radians per metre: standard deviation of the yaw error that driving adds."""

    def __post_init__(self) -> None:
        for name in ("translation", "rotation", "per_turn", "per_metre"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"MotionError.{name} must be a number >= 0, got {value}")

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """Four standard-normal draws scaled by the fields: ``(e_trans, e_rot, e_turn, e_metre)``."""
        scale = np.array([self.translation, self.rotation, self.per_turn, self.per_metre])
        draws: np.ndarray = rng.normal(0.0, 1.0, 4) * scale
        return draws

    @staticmethod
    def apply(command: np.ndarray, errors: np.ndarray) -> np.ndarray:
        """The true delta of ``command = (dx, dy, dyaw)`` under drawn ``errors`` (see :meth:`draw`)."""
        dx, dy, dyaw = (float(v) for v in command)
        e_trans, e_rot, e_turn, e_metre = (float(v) for v in errors)
        trans = math.hypot(dx, dy)
        turn = dyaw * (1 + e_rot) + (e_turn if dyaw != 0.0 else 0.0) + e_metre * trans
        return np.array([dx * (1 + e_trans), dy * (1 + e_trans), turn])


@dataclass(frozen=True)
class WorldConfig:
    """Everything the simulated world draws from besides the map."""

    laser: LaserSpec = field(default_factory=LaserSpec)
    motion_error: MotionError = field(default_factory=MotionError)
    """How the true motion departs from the commanded one."""
    odometry_error: MotionError = field(default_factory=lambda: MotionError(0.005, 0.005, 0.0, 0.002))
    """Random error of the odometry's measurement of the true motion (drawn as the motion's is)."""
    drift: Drift = field(default_factory=Drift)
    clutter: Clutter = field(default_factory=Clutter)
    robot_radius: float = 0.17
    """Metres: the base is a disc; it never overlaps an occupied or unknown pixel."""


class ContinuousWorld:
    """The map, the clutter placed on it, and where the robot may be.

    What rays hit: the map's occupied *and unknown* pixels (a SLAM map's unknown space lies behind
    walls, and its outline has gaps where a wall was seen poorly; a real laser hits the wall
    there) plus the clutter discs. The robot stands only on free pixels. Given an
    :class:`OccupancyImage` instead of a map, its ``blocked`` pixels are both."""

    def __init__(self, occupancy: OccupancyMap | OccupancyImage, config: WorldConfig, rng: np.random.Generator):
        if isinstance(occupancy, OccupancyMap):
            occupied = OccupancyImage.blocked_of(occupancy)
            standing = np.asarray(occupancy.pixels == Occupancy.FREE)
        else:
            occupied = occupancy
            standing = ~np.asarray(occupancy.blocked)
        self.config = config
        self.rng = rng
        self.map_image = occupied
        res = occupied.resolution
        clearance = np.maximum(ndimage.distance_transform_edt(standing) * res - res / 2, 0.0)
        self.clearance = clearance
        """Metres from each pixel's centre to the nearest edge of a pixel the robot cannot stand on
        (centre-to-centre distance less half a pixel; 0 on such a pixel)."""
        self.standable = clearance > config.robot_radius
        """Pixels that can hold the robot's centre (decided at the pixel's centre: a pixel's worth
        of tolerance)."""
        self.clutter_discs = np.zeros((0, 3))
        """``(x, y, radius)`` of each clutter disc, map frame."""
        self.image = occupied
        """What rays stop on besides the clutter discs (:meth:`cast`): the map's occupied and unknown pixels."""

    def place_clutter(self, keep_clear: Sequence[tuple[float, float]] = ()) -> None:
        """Draw :attr:`WorldConfig.clutter` discs in free space (centres at least
        :attr:`Clutter.keep_clear` metres from the given points, and far enough that the largest disc
        does not touch the robot standing there) and add them to the obstacles rays (:meth:`cast`) and
        the robot (:meth:`can_stand`) meet. Replaces earlier clutter."""
        spec = self.config.clutter
        # a radius is drawn for a kept centre alone, so the test takes the largest disc
        clear = max(spec.keep_clear, self.config.robot_radius + spec.radius[1])
        discs: list[tuple[float, float, float]] = []
        if spec.count:
            centres = self.random_poses(spec.count * 4)
            for x, y, _ in centres:
                if len(discs) == spec.count:
                    break
                if any(math.hypot(x - px, y - py) < clear for px, py in keep_clear):
                    continue
                discs.append((x, y, float(self.rng.uniform(*spec.radius))))
        self.clutter_discs = np.array(discs, dtype=np.float64).reshape(-1, 3)

    def cast(
        self, x: np.ndarray | float, y: np.ndarray | float, angle: np.ndarray | float, max_range: float
    ) -> np.ndarray:
        """The distance along each ray to the first thing it meets -- a blocked pixel of :attr:`image` or a
        clutter disc -- or ``+inf`` when nothing is within ``max_range``. The discs are met exactly
        (:func:`ray_disc_distances`), not drawn into the image: a hand-drawn grid's image has one pixel a
        cell, and a disc of 0.2 m drawn there blocks the whole cell."""
        ranges = cast_rays(self.image, x, y, angle, max_range)
        if len(self.clutter_discs):
            ranges = np.minimum(ranges, ray_disc_distances(x, y, angle, self.clutter_discs, max_range))
        return ranges

    def random_poses(self, count: int) -> np.ndarray:
        """``(count, 3)`` poses uniform over the standable space (a random standable pixel, a
        uniform point in it) with a uniform yaw."""
        i, j = np.nonzero(self.standable)
        if i.size == 0:
            raise ValueError("the map has no place where the robot fits")
        pick = self.rng.integers(0, i.size, size=count)
        image = self.map_image
        u = j[pick] + self.rng.uniform(0.0, 1.0, count)
        v = image.height - 1 - i[pick] + self.rng.uniform(0.0, 1.0, count)
        x, y = image.to_map(u, v)
        yaw = self.rng.uniform(-math.pi, math.pi, count)
        return np.stack([x, y, yaw], axis=1)

    def can_stand(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Whether the robot's centre can be at map point ``(x, y)`` (not clear of clutter)."""
        i, j = self.map_image.pixel_of(x, y)
        h, w = self.standable.shape
        inside = (i >= 0) & (i < h) & (j >= 0) & (j < w)
        ok = np.zeros(np.shape(inside), dtype=bool)
        ok[inside] = self.standable[i[inside], j[inside]]
        if len(self.clutter_discs):
            xa, ya = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
            d = np.hypot(xa[..., None] - self.clutter_discs[:, 0], ya[..., None] - self.clutter_discs[:, 1])
            ok &= np.all(d > self.clutter_discs[:, 2] + self.config.robot_radius, axis=-1)
        return ok

    def scan_ranges(self, laser_poses: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """The readings of :attr:`WorldConfig.laser` with beam ``b`` cast from ``laser_poses[b]``
        (map frame; one pose per beam, so that a sweep while moving is seen from where each beam
        was measured): ray-cast with noise, ``+inf`` beyond ``range_max``, ``-inf`` nearer than
        ``range_min``, spurious returns and dropouts by :attr:`WorldConfig.clutter`. Shape ``(beams,)``."""
        laser = self.config.laser
        p = np.asarray(laser_poses, dtype=np.float64).reshape(-1, 3)
        true = self.cast(p[:, 0], p[:, 1], p[:, 2] + angles, laser.range_max)
        n = true.size
        ranges = true + self.rng.normal(0.0, laser.range_sd, n)
        ranges[~np.isfinite(true)] = np.inf
        spec = self.config.clutter
        if spec.dropout:
            ranges[np.isfinite(ranges) & (self.rng.uniform(size=n) < spec.dropout)] = np.inf
        if spec.spurious:
            spurious = self.rng.uniform(size=n) < spec.spurious
            ranges[spurious] = self.rng.uniform(laser.range_min, laser.range_max, int(spurious.sum()))
        ranges[np.isfinite(ranges) & (ranges >= laser.range_max)] = np.inf
        ranges[ranges < laser.range_min] = -np.inf
        return ranges


def laser_pose(base: np.ndarray, mount: tuple[float, float, float]) -> np.ndarray:
    """Map-frame ``(x, y, yaw)`` of a laser mounted at ``mount`` on the base at ``base`` (shape ``(N, 3)``)."""
    return compose(np.asarray(base, dtype=np.float64).reshape(-1, 3), np.asarray(mount, dtype=np.float64))


class ContinuousRobot:
    """One robot in a :class:`ContinuousWorld`, step by step: it drives by a commanded delta, moves
    as its noisy base does (stopped where the map or clutter blocks it), reports its odometry, and
    scans from where it stands."""

    def __init__(self, world: ContinuousWorld, pose: tuple[float, float, float] | np.ndarray):
        self.world = world
        self.pose = np.asarray(pose, dtype=np.float64).reshape(3).copy()
        """The true pose ``(x, y, yaw)``, map frame."""
        self.odometry = np.zeros(3)
        """The odometry frame's pose of the base (starts at 0; drifts from the truth)."""

    def drive(
        self, command: tuple[float, float, float] | np.ndarray, errors: tuple[np.ndarray, np.ndarray] | None = None
    ) -> tuple[np.ndarray, bool]:
        """Drive by ``command = (dx, dy, dyaw)`` (robot frame at the start). Returns
        ``(odometry_delta, blocked)``: what the wheels measured (robot frame at the start), and whether
        the map or clutter stopped the motion partway (the robot then ends where it was stopped,
        with the turn done). ``errors``: the ``(motion, odometry)`` draws of :meth:`MotionError.draw`
        to use (a segment of a run keeps its draws); None draws new ones."""
        world = self.world
        config = world.config
        if errors is None:
            errors = (config.motion_error.draw(world.rng), config.odometry_error.draw(world.rng))
        start = self.pose.copy()
        true_delta = MotionError.apply(np.asarray(command, dtype=np.float64), errors[0])
        end = compose(start.reshape(1, 3), true_delta)[0]
        # stop where blocked: check the straight path at steps of a quarter pixel
        length = math.hypot(end[0] - start[0], end[1] - start[1])
        blocked = False
        if length > 0:
            steps = max(1, math.ceil(length / (world.map_image.resolution / 4)))
            f = np.linspace(0.0, 1.0, steps + 1)[1:]
            ok = world.can_stand(start[0] + f * (end[0] - start[0]), start[1] + f * (end[1] - start[1]))
            blocked = not bool(ok.all())
            if blocked:
                first = int(np.argmin(ok))
                frac = float(f[first - 1]) if first > 0 else 0.0
                end = np.array([start[0] + frac * (end[0] - start[0]), start[1] + frac * (end[1] - start[1]), end[2]])
                true_delta = relative(start, end)
        measured = _measure(true_delta, errors[1], config.drift)
        self.pose = end
        self.odometry = compose(self.odometry.reshape(1, 3), measured)[0]
        return measured, blocked

    def scan(self) -> np.ndarray:
        """A scan from the present pose (all beams at once): ``ranges (beams,)`` per REP 117."""
        laser = self.world.config.laser
        where = laser_pose(self.pose.reshape(1, 3), laser.mount)
        return self.world.scan_ranges(np.repeat(where, laser.beams, axis=0), laser.angles)


def _measure(true_delta: np.ndarray, errors: np.ndarray, drift: Drift) -> np.ndarray:
    """What the wheels report for the true motion ``true_delta``: its random error plus drift."""
    noisy = MotionError.apply(true_delta, errors)
    trans = math.hypot(noisy[0], noisy[1])
    return np.array(
        [
            noisy[0] * (1 + drift.scale),
            noisy[1] * (1 + drift.scale),
            noisy[2] * (1 + drift.turn_scale) + drift.yaw_rate * trans,
        ]
    )


# --- a timed run ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Segment:
    """One part of a run's plan: stand, turn in place or drive straight (speeds as a TurtleBot4's)."""

    kind: str
    """``"stand"``, ``"turn"`` or ``"drive"``."""
    amount: float
    """Seconds (stand), radians (turn, counter-clockwise positive) or metres (drive, forward positive)."""
    speed: float = 0.0
    """Rad/s (turn) or m/s (drive); ignored when standing."""

    def __post_init__(self) -> None:
        if self.kind not in ("stand", "turn", "drive"):
            raise ValueError(f"Segment.kind must be stand, turn or drive, got {self.kind!r}")
        if self.kind != "stand" and not self.speed > 0:
            raise ValueError(f"a {self.kind} segment needs a speed > 0")

    def duration(self) -> float:
        return self.amount if self.kind == "stand" else abs(self.amount) / self.speed


@dataclass(frozen=True)
class Run:
    """A simulated recording: what a bag holds, plus the truth.

    Stamps are integer nanoseconds since ``start_ns``'s epoch. Scans: ``scan_stamps (M,)`` (the time
    of the first beam, as ``header.stamp``), ``ranges (M, beams)`` per REP 117, and ``scan_truth (M, 3)``
    the true base pose at each scan stamp. Odometry: ``odom_stamps (K,)``, ``odom_poses (K, 3)`` the
    base in the ``odom`` frame (what ``/odom`` and ``odom -> base_link`` carry), ``odom_truth (K, 3)``."""

    laser: LaserSpec
    scan_stamps: np.ndarray
    ranges: np.ndarray
    scan_truth: np.ndarray
    odom_stamps: np.ndarray
    odom_poses: np.ndarray
    odom_truth: np.ndarray
    clutter: np.ndarray
    """``(x, y, radius)`` of the unmapped discs."""

    @property
    def duration_s(self) -> float:
        return (
            float(max(self.scan_stamps[-1], self.odom_stamps[-1]) - min(self.scan_stamps[0], self.odom_stamps[0])) / 1e9
        )


def simulate_run(
    world: ContinuousWorld,
    start: tuple[float, float, float] | np.ndarray,
    plan: Sequence[Segment],
    *,
    start_ns: int = 1_700_000_000_000_000_000,
    odom_rate: float = 20.0,
    scan_rate: float = 7.77,
    dt: float = 0.005,
) -> Run:
    """Drive the robot from ``start`` (map frame) through ``plan`` and record it.

    The truth is integrated every ``dt`` seconds (the commanded velocity with the world's motion
    noise); odometry is sampled at ``odom_rate`` Hz, scans at ``scan_rate`` Hz with stamps that jitter
    by a few milliseconds and are not aligned with the odometry's; beam ``b`` of a scan is cast
    from the true pose at ``stamp + b * time_increment`` (a sweep while turning is skewed, as a
    real lidar's). Clutter, when the config asks for it, is placed first (away from ``start``)."""
    rng = world.rng
    laser = world.config.laser
    robot = ContinuousRobot(world, start)
    if world.config.clutter.count:
        world.place_clutter(keep_clear=[(float(start[0]), float(start[1]))])
    # commanded deltas per dt step, each segment with its own error draws
    commands: list[tuple[tuple[float, float, float], int]] = []
    for index, seg in enumerate(plan):
        steps = max(1, round(seg.duration() / dt))
        if seg.kind == "stand":
            commands += [((0.0, 0.0, 0.0), index)] * steps
        elif seg.kind == "turn":
            commands += [((0.0, 0.0, seg.amount / steps), index)] * steps
        else:
            commands += [((seg.amount / steps, 0.0, 0.0), index)] * steps
    draws = [(world.config.motion_error.draw(rng), world.config.odometry_error.draw(rng)) for _ in plan]
    for motion, _ in draws:
        motion[2] = 0.0  # the per-turn error is spread over the segment's steps below
    turn_errors = [float(rng.normal(0.0, world.config.motion_error.per_turn)) for _ in plan]
    times = np.arange(len(commands) + 1) * dt
    truth = np.empty((len(commands) + 1, 3))
    odom = np.empty((len(commands) + 1, 3))
    truth[0], odom[0] = robot.pose, robot.odometry
    for n, (command, index) in enumerate(commands):
        if command != (0.0, 0.0, 0.0):
            seg = plan[index]
            turn = command[2] + (turn_errors[index] * command[2] / seg.amount if seg.kind == "turn" else 0.0)
            robot.drive((command[0], command[1], turn), draws[index])
        truth[n + 1], odom[n + 1] = robot.pose, robot.odometry
    total = float(times[-1])

    def at(series: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Linear interpolation of poses in time (yaw unwrapped)."""
        yaw = np.unwrap(series[:, 2])
        return np.stack(
            [
                np.interp(t, times, series[:, 0]),
                np.interp(t, times, series[:, 1]),
                wrap_angle(np.interp(t, times, yaw)),
            ],
            axis=1,
        )

    odom_t = np.arange(0.013, total, 1.0 / odom_rate)
    scan_t = np.arange(0.041, total - laser.scan_time, 1.0 / scan_rate)
    scan_t = scan_t + rng.uniform(-0.004, 0.004, scan_t.size)
    ranges = np.empty((scan_t.size, laser.beams))
    beam_dt = laser.time_increment * np.arange(laser.beams)
    for m, t in enumerate(scan_t):
        where = laser_pose(at(truth, t + beam_dt), laser.mount)
        ranges[m] = world.scan_ranges(where, laser.angles)

    def to_ns(t: np.ndarray) -> np.ndarray:
        stamps: np.ndarray = np.int64(start_ns) + np.round(t * 1e9).astype(np.int64)  # exact ns
        return stamps

    return Run(
        laser=laser,
        scan_stamps=to_ns(scan_t),
        ranges=ranges,
        scan_truth=at(truth, scan_t),
        odom_stamps=to_ns(odom_t),
        odom_poses=at(odom, odom_t),
        odom_truth=at(truth, odom_t),
        clutter=world.clutter_discs.copy(),
    )
