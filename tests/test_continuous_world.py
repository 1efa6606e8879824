"""The continuous simulated world: poses in free space, blocked motion, drifting odometry, REP 117
scans, clutter, skewed sweeps and a timed run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.motion import compose
from beliefloc.continuous.raycast import cast_rays
from beliefloc.continuous.world import (
    Clutter,
    ContinuousRobot,
    ContinuousWorld,
    Drift,
    LaserSpec,
    MotionError,
    Segment,
    WorldConfig,
    laser_pose,
    simulate_run,
)
from beliefloc.model import MapFrame
from beliefloc.semantic_map.occupancy_map import load_occupancy
from tests.conftest import MAPS

SANDBOX = MAPS / "occupancy" / "tb3_sandbox.yaml"
EXACT = WorldConfig(motion_error=MotionError(0, 0, 0, 0), odometry_error=MotionError(0, 0, 0, 0))


def _room() -> OccupancyImage:
    """A 4 m x 3 m room with walls one pixel thick, 0.05 m pixels, origin at (-1, -1)."""
    blocked = np.zeros((60, 80), dtype=bool)
    blocked[0, :] = blocked[-1, :] = blocked[:, 0] = blocked[:, -1] = True
    return OccupancyImage(blocked, 0.05, MapFrame(-1.0, -1.0, 0.0))


def test_random_poses_are_where_the_robot_fits() -> None:
    world = ContinuousWorld(load_occupancy(SANDBOX), WorldConfig(), np.random.default_rng(0))
    poses = world.random_poses(500)
    assert world.can_stand(poses[:, 0], poses[:, 1]).all()
    assert np.ptp(poses[:, 2]) > 6.0  # any yaw
    i, j = world.map_image.pixel_of(poses[:, 0], poses[:, 1])
    assert world.clearance[i, j].min() > world.config.robot_radius


def test_exact_drive_is_the_command_and_odometry_agrees() -> None:
    world = ContinuousWorld(_room(), EXACT, np.random.default_rng(0))
    robot = ContinuousRobot(world, (0.5, 0.5, 0.3))
    measured, blocked = robot.drive((0.4, 0.1, 0.2))
    assert not blocked
    assert measured == pytest.approx([0.4, 0.1, 0.2])
    assert robot.pose == pytest.approx(compose(np.array([[0.5, 0.5, 0.3]]), (0.4, 0.1, 0.2))[0])


def test_a_turn_in_place_never_moves_the_base() -> None:
    world = ContinuousWorld(_room(), WorldConfig(), np.random.default_rng(1))
    robot = ContinuousRobot(world, (0.5, 0.5, 0.0))
    for _ in range(300):
        robot.drive((0.0, 0.0, 0.01))
    assert robot.pose[:2] == pytest.approx([0.5, 0.5])
    assert robot.odometry[:2] == pytest.approx([0.0, 0.0])


def test_a_wall_stops_the_robot_partway() -> None:
    world = ContinuousWorld(_room(), EXACT, np.random.default_rng(0))
    robot = ContinuousRobot(world, (2.0, 0.5, 0.0))  # the east wall is at x = 2.95
    measured, blocked = robot.drive((3.0, 0.0, 0.0))
    assert blocked
    stop = 2.95 - world.config.robot_radius
    assert stop - 0.05 < robot.pose[0] <= stop + 0.05  # standing is decided per pixel
    assert measured[0] == pytest.approx(robot.pose[0] - 2.0)


def test_drift_makes_odometry_depart_from_the_truth() -> None:
    config = WorldConfig(
        motion_error=MotionError(0, 0, 0, 0), odometry_error=MotionError(0, 0, 0, 0), drift=Drift(0.05, 0.1, 0.0)
    )
    world = ContinuousWorld(_room(), config, np.random.default_rng(0))
    robot = ContinuousRobot(world, (-0.5, 0.5, 0.0))
    measured, _ = robot.drive((2.0, 0.0, 0.0))
    assert measured[0] == pytest.approx(2.1)
    assert measured[2] == pytest.approx(0.2)
    assert robot.pose == pytest.approx([1.5, 0.5, 0.0])


def test_scan_follows_rep_117_and_the_mount() -> None:
    laser = LaserSpec(beams=360, angle_min=-math.pi, angle_max=math.pi - 2 * math.pi / 360, range_max=2.0, range_sd=0.0)
    world = ContinuousWorld(_room(), WorldConfig(laser=laser), np.random.default_rng(0))
    robot = ContinuousRobot(world, (-0.5, 0.5, 0.0))
    ranges = robot.scan()
    assert ranges.shape == (360,)
    assert np.isposinf(ranges).any()  # the far walls are beyond 2 m
    finite = ranges[np.isfinite(ranges)]
    assert finite.min() >= laser.range_min and finite.max() < laser.range_max
    # the laser is rotated +90°: its beam at -90° looks along the base's +x (east, wall at x = 2.95)
    # and its beam at 180° looks along the base's -y (south, wall at y = -0.95)
    east = ranges[int(np.argmin(np.abs(laser.angles + math.pi / 2)))]
    assert math.isinf(east)  # 3.45 m away
    south = ranges[int(np.argmin(np.abs(np.abs(laser.angles) - math.pi)))]
    assert south == pytest.approx(1.45, abs=0.02)


def test_too_close_reads_minus_inf() -> None:
    laser = LaserSpec(beams=8, angle_min=0.0, angle_max=7 * math.pi / 4, range_min=0.5, range_sd=0.0, mount=(0, 0, 0))
    world = ContinuousWorld(_room(), WorldConfig(laser=laser, robot_radius=0.1), np.random.default_rng(0))
    ranges = ContinuousRobot(world, (2.7, 0.5, 0.0)).scan()
    assert ranges[0] == -math.inf  # the east wall 0.25 m ahead


def test_clutter_is_unmapped_and_shortens_beams() -> None:
    occupancy = load_occupancy(SANDBOX)
    config = WorldConfig(clutter=Clutter(count=12, radius=(0.15, 0.25)))
    shortened = 0
    for seed in range(5):
        world = ContinuousWorld(occupancy, config, np.random.default_rng(seed))
        start = world.random_poses(1)[0]
        world.place_clutter(keep_clear=[(start[0], start[1])])
        assert world.clutter_discs.shape == (12, 3)
        apart = np.hypot(world.clutter_discs[:, 0] - start[0], world.clutter_discs[:, 1] - start[1])
        assert apart.min() >= 0.5  # keep_clear, from the start to each centre
        # a ray aimed at a disc's centre from the start meets it at its edge, or something nearer first
        for x, y, radius in world.clutter_discs:
            aim = math.atan2(y - start[1], x - start[0])
            distance = math.hypot(x - start[0], y - start[1])
            with_clutter = float(world.cast(start[0], start[1], aim, 20.0))
            assert with_clutter <= distance - radius + 1e-9
            mapped = float(cast_rays(world.image, start[0], start[1], aim, 20.0))
            assert with_clutter <= mapped
            shortened += with_clutter < mapped
    assert shortened >= 15  # of 60 discs, those not behind a wall from the start


def test_no_disc_stands_where_the_robot_does() -> None:
    """A wide robot with a small keep_clear still starts free of every disc."""
    occupancy = load_occupancy(SANDBOX)
    config = WorldConfig(robot_radius=0.3, clutter=Clutter(count=40, radius=(0.25, 0.3), keep_clear=0.05))
    for seed in range(5):
        world = ContinuousWorld(occupancy, config, np.random.default_rng(seed))
        start = world.random_poses(1)[0]
        world.place_clutter(keep_clear=[(start[0], start[1])])
        apart = np.hypot(world.clutter_discs[:, 0] - start[0], world.clutter_discs[:, 1] - start[1])
        assert (apart - world.clutter_discs[:, 2]).min() >= 0.3
        assert world.can_stand(start[0], start[1])


def test_a_sweep_while_turning_is_skewed() -> None:
    """Beams are cast from the pose at their own time: a run that turns during a sweep differs
    from one scan taken at the stamp's pose."""
    occupancy = load_occupancy(SANDBOX)
    config = WorldConfig(laser=LaserSpec(range_sd=0.0), motion_error=MotionError(0, 0, 0, 0))
    world = ContinuousWorld(occupancy, config, np.random.default_rng(5))
    start = (0.0, -1.5, 0.0)
    run = simulate_run(world, start, [Segment("turn", 2 * math.pi, 1.0)])
    m = len(run.scan_stamps) // 2
    where = laser_pose(run.scan_truth[m : m + 1], config.laser.mount)
    still = cast_rays(world.image, where[0, 0], where[0, 1], where[0, 2] + config.laser.angles, 12.0)
    both = np.isfinite(still) & np.isfinite(run.ranges[m])
    assert np.abs(still[both] - run.ranges[m][both]).max() > 0.05


def test_a_run_has_unaligned_stamps_and_drifting_odometry() -> None:
    occupancy = load_occupancy(SANDBOX)
    config = WorldConfig(drift=Drift(scale=0.03, yaw_rate=0.05), clutter=Clutter(count=4, spurious=0.01, dropout=0.1))
    world = ContinuousWorld(occupancy, config, np.random.default_rng(7))
    plan = [Segment("stand", 1.0), Segment("turn", math.pi / 2, 0.8), Segment("drive", 0.6, 0.25)]
    run = simulate_run(world, (0.0, -1.5, 0.0), plan)
    assert run.ranges.shape == (run.scan_stamps.size, 720)
    assert np.all(np.diff(run.scan_stamps) > 0) and np.all(np.diff(run.odom_stamps) > 0)
    assert 15 < 1e9 / np.diff(run.odom_stamps).mean() < 25  # ~20 Hz
    assert 6 < 1e9 / np.diff(run.scan_stamps).mean() < 10  # ~8 Hz
    assert not np.isin(run.scan_stamps, run.odom_stamps).any()
    assert run.duration_s == pytest.approx(sum(seg.duration() for seg in plan), abs=0.3)
    # odometry starts at the identity; its motion departs from the truth's by the drift
    assert run.odom_poses[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-6)
    odom_travel = np.hypot(*(run.odom_poses[-1, :2] - run.odom_poses[0, :2]))
    true_travel = np.hypot(*(run.odom_truth[-1, :2] - run.odom_truth[0, :2]))
    assert odom_travel > true_travel * 1.01
    assert np.isposinf(run.ranges).any() and np.isfinite(run.ranges).mean() > 0.3


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(ValueError, match="range_min"):
        LaserSpec(range_min=0.0)
    with pytest.raises(ValueError, match="translation"):
        MotionError(translation=-1.0)
    with pytest.raises(ValueError, match="kind"):
        Segment("jump", 1.0)
