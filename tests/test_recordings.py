"""Reading recordings (rosbag2 sqlite3 / MCAP, ROS 1) and ``track MAP --bag``: the committed short
depot run (tests/data/bags/, written by tools/make_test_bags.py) and broken recordings."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.continuous.grid_filter import FilterConfig
from beliefloc.errors import RecordingError
from beliefloc.recordings.reader import read_recording
from beliefloc.recordings.replay import track_recording
from beliefloc.recordings.writer import FrameSpec
from beliefloc.semantic_map.occupancy_map import load_occupancy
from tests.conftest import DATA, MAPS

BAGS = DATA / "bags"
COPIES = {
    "sqlite3": BAGS / "depot_short_sqlite3",
    "mcap": BAGS / "depot_short_mcap",
    "ros1": BAGS / "depot_short_ros1.bag",
}
DEPOT_YAML = MAPS / "occupancy" / "depot.yaml"
DEPOT_MAP = MAPS / "depot.yaml"
FAST = FilterConfig(cell_size=0.2, headings=16)
"""A coarse filter: these tests are about reading, not accuracy (tests/test_track_bag_runs.py)."""


@pytest.mark.parametrize("storage", sorted(COPIES))
def test_every_storage_reads_the_same(storage: str) -> None:
    rec = read_recording(COPIES[storage])
    ref = read_recording(COPIES["sqlite3"])
    assert rec.scan_topic == "/scan"
    assert rec.base_frame == "base_link" and rec.laser_frame == "rplidar_link"
    assert rec.mount == pytest.approx(FrameSpec().mount)  # through shell_link, rotated +90 degrees
    assert rec.mount[2] == pytest.approx(math.pi / 2)
    assert len(rec.scans) == len(ref.scans) > 10
    assert [s.stamp for s in rec.scans] == [s.stamp for s in ref.scans]
    assert np.array_equal(rec.scans[3].ranges, ref.scans[3].ranges, equal_nan=True)
    assert rec.odom_poses == pytest.approx(ref.odom_poses)
    assert len(rec.scans[0].ranges) == 720
    assert rec.scans[0].angle_min == pytest.approx(-3.124) and rec.scans[0].range_max == pytest.approx(12.0)
    assert np.isposinf(rec.scans[0].ranges).any()  # REP 117: no return
    truth = np.load(BAGS / "depot_short_truth.npz")
    assert [s.stamp for s in rec.scans] == truth["scan_stamps"].tolist()


def test_the_same_final_pose_from_every_storage() -> None:
    occupancy = load_occupancy(DEPOT_YAML)
    results = [track_recording(occupancy, read_recording(path), FAST) for path in COPIES.values()]
    first = results[0]
    for other in results[1:]:
        assert other.pose == pytest.approx(first.pose)
        assert other.localized == first.localized
        assert [u.as_json() for u in other.updates] == [u.as_json() for u in first.updates]


def test_odometry_from_tf_matches_the_odometry_topic() -> None:
    by_topic = read_recording(COPIES["mcap"])
    by_tf = read_recording(COPIES["mcap"], odom_topic="/tf")
    assert by_tf.odometry_source == "/tf odom -> base_link"
    assert by_tf.odom_poses == pytest.approx(by_topic.odom_poses)
    stamps = np.array([s.stamp for s in by_topic.scans])
    assert by_tf.odometry_at(stamps) == pytest.approx(by_topic.odometry_at(stamps))


def test_odometry_is_interpolated_at_scan_stamps() -> None:
    rec = read_recording(COPIES["sqlite3"])
    stamps = np.array([s.stamp for s in rec.scans])
    assert not np.isin(stamps, rec.odom_stamps).any()  # not synchronised
    k = 10
    after = int(np.searchsorted(rec.odom_stamps, stamps[k]))
    t0, t1 = rec.odom_stamps[after - 1], rec.odom_stamps[after]
    f = (stamps[k] - t0) / (t1 - t0)
    expected = (1 - f) * rec.odom_poses[after - 1, :2] + f * rec.odom_poses[after, :2]
    assert rec.odometry_at(stamps[k : k + 1])[0, :2] == pytest.approx(expected, abs=1e-6)


def test_laser_pose_override() -> None:
    rec = read_recording(COPIES["ros1"], laser_pose=(0.1, 0.0, 0.0))
    assert rec.mount == (0.1, 0.0, 0.0)


def test_yaw_offsets_follow_the_turn_during_a_sweep() -> None:
    rec = read_recording(COPIES["sqlite3"])
    turning = max(rec.scans, key=lambda s: abs(rec.yaw_rate(s.stamp)))
    offsets = rec.yaw_offsets(turning)
    rate = rec.yaw_rate(turning.stamp)
    assert abs(rate) > 0.5
    assert offsets[0] == 0.0
    assert offsets[-1] == pytest.approx(rate * turning.time_increment * (len(offsets) - 1), rel=0.1)


BROKEN = [
    ("broken_no_metadata", "no metadata.yaml"),
    ("broken_corrupt_db3", "cannot be read as a ROS recording"),
    ("broken_no_scan", "no LaserScan topic"),
    ("broken_zero_increment", "topic /scan, scan 1 .*angle_increment is 0"),
    ("broken_odometry_jump", "topic /odom: the odometry jumps 100 m"),
]


@pytest.mark.parametrize(("name", "message"), BROKEN)
def test_broken_recordings_are_refused_by_name(name: str, message: str) -> None:
    with pytest.raises(RecordingError, match=message) as info:
        read_recording(BAGS / name)
    assert str(BAGS / name) in str(info.value)


@pytest.mark.parametrize(("name", "message"), BROKEN)
def test_track_bag_exits_2_and_writes_nothing(runner: CliRunner, tmp_path: Path, name: str, message: str) -> None:
    belief = tmp_path / "belief.json"
    result = runner.invoke(app, ["track", str(DEPOT_MAP), "--bag", str(BAGS / name), "--belief-out", str(belief)])
    assert result.exit_code == 2, result.output
    assert name in result.output
    assert "Traceback" not in result.output
    assert not belief.exists()


def test_message_type_not_read_and_missing_topic(runner: CliRunner) -> None:
    bag = str(COPIES["mcap"])
    result = runner.invoke(app, ["track", str(DEPOT_YAML), "--bag", bag, "--odom-topic", "/cmd_vel"])
    assert result.exit_code == 2
    assert "/cmd_vel carries geometry_msgs/msg/Twist, a message type beliefloc does not read" in result.output
    result = runner.invoke(app, ["track", str(DEPOT_YAML), "--bag", bag, "--scan-topic", "/nothing"])
    assert result.exit_code == 2
    assert "has no topic /nothing" in result.output


def test_scan_frame_without_a_path_to_the_base(tmp_path: Path) -> None:
    from beliefloc.continuous.world import Segment
    from beliefloc.recordings.scenarios import Scenario, simulate_scenario
    from beliefloc.recordings.writer import write_run

    run = simulate_scenario(load_occupancy(DEPOT_YAML), Scenario("tiny", (Segment("stand", 0.5),), seed=1))
    frames = FrameSpec(intermediate="plate", base_to_intermediate=(0.0, 0.0, 0.0))
    bag = tmp_path / "loose"
    write_run(run, bag, "mcap", frames=frames, scan_frame="laser_nowhere")
    with pytest.raises(RecordingError, match="scan's frame 'laser_nowhere' has no path to the base frame 'base_link'"):
        read_recording(bag)
    assert read_recording(bag, laser_pose=(0.0, 0.0, 1.57)).mount == (0.0, 0.0, 1.57)


def test_track_bag_json_shape(runner: CliRunner) -> None:
    args = ["track", str(DEPOT_YAML), "--bag", str(COPIES["mcap"]), "--json", "--cell-size", "0.2", "--headings", "16"]
    result = runner.invoke(app, args)
    assert result.exit_code in (0, 1), result.output
    data = json.loads(result.stdout)
    assert set(data) >= {"localized", "pose", "timeline"}
    assert set(data["pose"]) == {"x", "y", "yaw", "covariance"} and len(data["pose"]["covariance"]) == 36
    entry = data["timeline"][0]
    assert set(entry) == {"stamp", "x", "y", "yaw", "max_probability", "localized"}
    assert isinstance(entry["stamp"], int)
    stamps = {s.stamp for s in read_recording(COPIES["mcap"]).scans}
    assert all(e["stamp"] in stamps for e in data["timeline"])
    assert (result.exit_code == 0) == data["localized"]


def test_belief_out_feeds_pose_format_ros(runner: CliRunner, tmp_path: Path) -> None:
    belief = tmp_path / "belief.json"
    args = ["track", str(DEPOT_MAP), "--bag", str(COPIES["sqlite3"]), "--belief-out", str(belief)]
    result = runner.invoke(app, [*args, "--cell-size", "0.2", "--headings", "16"])
    assert result.exit_code in (0, 1), result.output
    assert belief.exists()
    pose = runner.invoke(app, ["pose", str(DEPOT_MAP), "--belief", str(belief), "--format", "ros", "--force"])
    assert pose.exit_code == 0, pose.output
    assert "covariance" in pose.stdout and "frame_id: map" in pose.stdout


def test_belief_out_needs_a_beliefloc_map(runner: CliRunner, tmp_path: Path) -> None:
    belief = tmp_path / "belief.json"
    result = runner.invoke(app, ["track", str(DEPOT_YAML), "--bag", str(COPIES["mcap"]), "--belief-out", str(belief)])
    assert result.exit_code == 2
    assert "plain map_server YAML" in result.output
    assert not belief.exists()


def test_bag_options_without_bag_and_steps_with_bag(runner: CliRunner) -> None:
    result = runner.invoke(app, ["track", str(DEPOT_MAP), "--scan-topic", "/scan", "look=nothing"])
    assert result.exit_code == 2 and "--scan-topic goes with --bag" in result.output
    result = runner.invoke(app, ["track", str(DEPOT_YAML), "--bag", str(COPIES["mcap"]), "look=nothing"])
    assert result.exit_code == 2 and "--bag RUN replaces STEP" in result.output
    result = runner.invoke(app, ["track", str(DEPOT_YAML), "--bag", str(COPIES["mcap"]), "--laser-pose", "1,2"])
    assert result.exit_code == 2 and "--laser-pose '1,2'" in result.output


def test_picture(runner: CliRunner, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    picture = tmp_path / "track.png"
    args = ["track", str(DEPOT_YAML), "--bag", str(COPIES["mcap"]), "-o", str(picture), "--cell-size", "0.2"]
    result = runner.invoke(app, [*args, "--headings", "16"])
    assert result.exit_code in (0, 1), result.output
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_coarse_filter_is_not_confidently_wrong_on_the_short_run() -> None:
    """0.2 m cells prune the true place in the first updates; the global rival search must still
    find it before a look-alike aisle 15 m away is called."""
    occupancy = load_occupancy(DEPOT_YAML)
    result = track_recording(occupancy, read_recording(COPIES["mcap"]), FAST)
    truth = np.load(BAGS / "depot_short_truth.npz")
    for u in result.updates:
        t = truth["scan_truth"][int(np.argmin(np.abs(truth["scan_stamps"] - u.stamp)))]
        assert not (u.localized and math.hypot(u.x - t[0], u.y - t[1]) > 1.0)


def test_track_bag_text(runner: CliRunner) -> None:
    args = ["track", str(DEPOT_YAML), "--bag", str(COPIES["ros1"]), "--cell-size", "0.2", "--headings", "16"]
    result = runner.invoke(app, args)
    assert result.exit_code in (0, 1), result.output
    assert "scans on /scan, odometry from /odom (nav_msgs/msg/Odometry), laser rplidar_link" in result.stdout
    if result.exit_code == 0:
        assert "localized at" in result.stdout and "final pose: x" in result.stdout
    else:
        assert "not localized:" in result.stdout and "mode 1: p" in result.stdout
