"""Generated recordings tracked end to end: localized where the run is informative, never
confidently wrong (declared localized > 1 m or 30 degrees from the truth), the same result
whichever way the bag stores it. Slow: each run is simulated, written and tracked."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from beliefloc.continuous.grid_filter import FilterConfig
from beliefloc.continuous.world import Clutter, Drift, Segment
from beliefloc.recordings.reader import read_recording
from beliefloc.recordings.replay import TrackResult, track_recording
from beliefloc.recordings.scenarios import (
    TURTLEBOT4_WORLD,
    Scenario,
    corridor_map,
    issue_plan,
    simulate_scenario,
    write_scenario,
)
from beliefloc.recordings.writer import write_run
from beliefloc.semantic_map.occupancy_map import load_occupancy
from tests.conftest import MAPS

DEPOT = MAPS / "occupancy" / "depot.yaml"
SANDBOX = MAPS / "occupancy" / "tb3_sandbox.yaml"
DEPOT_PLAN = (Segment("stand", 2.0), Segment("turn", math.pi, 0.6), Segment("drive", 3.0, 0.3))
SANDBOX_PLAN = (Segment("stand", 1.0), Segment("turn", 2.5, 0.6), Segment("drive", 0.8, 0.25))

HEAVY_CLUTTER = TURTLEBOT4_WORLD.__class__(
    laser=TURTLEBOT4_WORLD.laser,
    drift=Drift(scale=0.05, yaw_rate=0.05, turn_scale=0.03),
    clutter=Clutter(count=40, radius=(0.15, 0.4), spurious=0.05, dropout=0.2),
)
"""Forty unmapped discs, 5 % spurious returns, 20 % dropouts, 5 % odometry drift."""

pytestmark = pytest.mark.slow


def _confidently_wrong(result: TrackResult, truth: dict[str, np.ndarray]) -> int:
    wrong = 0
    for u in result.updates:
        i = int(np.argmin(np.abs(truth["scan_stamps"] - u.stamp)))
        t = truth["scan_truth"][i]
        far = math.hypot(u.x - t[0], u.y - t[1]) > 1.0
        turned = abs(math.remainder(u.yaw - t[2], 2 * math.pi)) > math.radians(30)
        wrong += int(u.localized and (far or turned))
    return wrong


def _run(tmp_path: Path, yaml: Path, scenario: Scenario) -> tuple[TrackResult, dict[str, np.ndarray], Path]:
    occupancy = load_occupancy(yaml)
    run = simulate_scenario(occupancy, scenario)
    paths = write_scenario(run, tmp_path, scenario.name, ("sqlite3",))
    truth = dict(np.load(tmp_path / f"{scenario.name}_truth.npz"))
    return track_recording(occupancy, read_recording(paths["sqlite3"]), FilterConfig()), truth, paths["sqlite3"]


@pytest.mark.slow
def test_an_informative_depot_run_ends_localized_at_the_truth(tmp_path: Path) -> None:
    result, truth, _ = _run(tmp_path, DEPOT, Scenario("depot", DEPOT_PLAN, seed=100))
    assert result.localized
    t = truth["scan_truth"][-1]
    assert math.hypot(result.pose[0] - t[0], result.pose[1] - t[1]) < 0.15
    assert abs(math.remainder(result.pose[2] - t[2], 2 * math.pi)) < math.radians(5)
    assert _confidently_wrong(result, truth) == 0
    assert result.localized_at is not None


@pytest.mark.slow
def test_a_self_similar_corridor_run_stays_localized_once_told_apart(tmp_path: Path) -> None:
    """The issue's 46 s plan on the office floor's corridor, whose look-alikes lie every 4 m. Once
    told apart, the place stays localized to the end while the belief follows it and no rival does
    better -- though for a while the remembered scans, all corridor, cannot tell it from the
    look-alikes (without the hold the verdict lapsed for 9 updates here) --, at the truth, and never
    confidently wrong."""
    result, truth, _ = _run(tmp_path, corridor_map(tmp_path / "map"), Scenario("corridor", issue_plan(), seed=100))
    assert result.localized
    verdicts = [u.localized for u in result.updates]
    first = verdicts.index(True)
    assert all(verdicts[first:])
    t = truth["scan_truth"][-1]
    assert math.hypot(result.pose[0] - t[0], result.pose[1] - t[1]) < 0.15
    assert abs(math.remainder(result.pose[2] - t[2], 2 * math.pi)) < math.radians(5)
    assert _confidently_wrong(result, truth) == 0


@pytest.mark.parametrize("seed", [100, 101])
def test_the_nearly_symmetric_sandbox_is_never_confidently_wrong(tmp_path: Path, seed: int) -> None:
    result, truth, _ = _run(tmp_path, SANDBOX, Scenario("sandbox", SANDBOX_PLAN, seed=seed))
    assert _confidently_wrong(result, truth) == 0
    if not result.localized:
        assert result.reason


@pytest.mark.slow
def test_heavy_clutter_and_drift_are_never_confidently_wrong(tmp_path: Path) -> None:
    result, truth, _ = _run(tmp_path, DEPOT, Scenario("cluttered", DEPOT_PLAN, world=HEAVY_CLUTTER, seed=102))
    assert _confidently_wrong(result, truth) == 0


@pytest.mark.slow
def test_clockwise_scans_and_tf_odometry_give_the_same_pose(tmp_path: Path) -> None:
    occupancy = load_occupancy(DEPOT)
    run = simulate_scenario(occupancy, Scenario("depot", DEPOT_PLAN, seed=103))
    plain, reversed_, tf_only = tmp_path / "plain", tmp_path / "reversed", tmp_path / "tf"
    write_run(run, plain, "mcap")
    write_run(run, reversed_, "mcap", scan_angle_sign=-1)
    write_run(run, tf_only, "mcap", odometry_topic=False)
    config = FilterConfig()
    results = [track_recording(occupancy, read_recording(p), config) for p in (plain, reversed_, tf_only)]
    assert read_recording(tf_only).odometry_source == "/tf odom -> base_link"
    assert read_recording(reversed_).scans[0].angle_increment < 0
    for other in results[1:]:
        assert other.localized == results[0].localized
        assert other.pose == pytest.approx(results[0].pose, abs=0.03)


def test_clutter_that_favours_the_sandbox_twin_is_not_evidence(tmp_path: Path) -> None:
    """Seed 302: two of the ten unmapped discs stand by the wall where the mirror twin's map has a
    wall, and give the twin 5 nats in every scan; the rival comparison sets aside what a few
    objects could have made (``FilterConfig.clutter_objects``), so the twin, 3.6 m and 180 degrees
    away, is not called. (A strict xfail until the comparison was trimmed.)"""
    result, truth, _ = _run(tmp_path, SANDBOX, Scenario("sandbox", SANDBOX_PLAN, seed=302))
    assert _confidently_wrong(result, truth) == 0
    assert not result.localized
    assert result.reason


@pytest.mark.parametrize("seed", [1, 9])
def test_a_sandbox_twin_is_told_apart_by_the_beams_that_would_cross_its_walls(tmp_path: Path, seed: int) -> None:
    """Seeds 1 and 9 (ten discs): the run ends at the truth, and its mirror twin is told apart by
    beams that, with the robot at the twin, would have passed through the twin's walls -- evidence
    no unmapped object makes, so the clutter trim keeps it (``FilterConfig.wall_tolerance``). Before
    it did, the trim set that evidence aside with the rest and both runs ended "not localized"."""
    result, truth, _ = _run(tmp_path, SANDBOX, Scenario("sandbox", SANDBOX_PLAN, seed=seed))
    assert _confidently_wrong(result, truth) == 0
    assert result.localized
    t = truth["scan_truth"][-1]
    assert math.hypot(result.pose[0] - t[0], result.pose[1] - t[1]) < 0.15
    assert abs(math.remainder(result.pose[2] - t[2], 2 * math.pi)) < math.radians(5)


@pytest.mark.parametrize(
    ("map_name", "seed"),
    [("sandbox", 66), ("sandbox", 199), ("sandbox", 232), ("depot", 105), ("depot", 108), ("depot", 113)],
)
def test_the_runs_that_were_confidently_wrong_under_clutter_are_not(tmp_path: Path, map_name: str, seed: int) -> None:
    """The generated runs that ended confidently wrong before the rival comparison was trimmed for
    clutter (issue 27's sweep: the sandbox with its ten discs, seeds 0-234 and 302; the depot with
    forty discs, 5 % spurious returns, 20 % dropouts and 5 % drift, seeds 100-115)."""
    if map_name == "sandbox":
        scenario = Scenario("sandbox", SANDBOX_PLAN, seed=seed)
        yaml = SANDBOX
    else:
        scenario = Scenario("cluttered", DEPOT_PLAN, world=HEAVY_CLUTTER, seed=seed)
        yaml = DEPOT
    result, truth, _ = _run(tmp_path, yaml, scenario)
    assert _confidently_wrong(result, truth) == 0
    if not result.localized:
        assert result.reason
