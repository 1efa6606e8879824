"""``track --bag --record`` and ``simulate --record FILE.mcap``: the recordings read back with a
third-party reader (``mcap`` + ``mcap-ros2-support``, not rosbags, which wrote them) and checked
message by message against the run."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.pose import state_pose
from beliefloc.recordings.reader import read_recording
from beliefloc.recordings.record import open_recording
from beliefloc.ros import messages
from beliefloc.semantic_map import compile_model, load_map
from beliefloc.semantic_map.occupancy_map import load_occupancy
from tests.conftest import DATA, MAPS

BAG = DATA / "bags" / "depot_short_mcap"
DEPOT_YAML = MAPS / "occupancy" / "depot.yaml"
FAST = ["--cell-size", "0.2", "--headings", "16"]
"""A coarse filter: the recording is under test, not the localization."""

TYPES = {
    "/map": "nav_msgs/msg/OccupancyGrid",
    "/scan": "sensor_msgs/msg/LaserScan",
    "/odom": "nav_msgs/msg/Odometry",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/beliefloc/belief": "geometry_msgs/msg/PoseArray",
    "/beliefloc/belief_cells": "visualization_msgs/msg/MarkerArray",
    "/beliefloc/pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
}


@dataclass
class Read:
    log_time: int
    msg: Any


@dataclass
class Recorded:
    types: dict[str, str]
    qos: dict[str, str]
    topics: dict[str, list[Read]]


def read_mcap(path: Path) -> Recorded:
    """Every message, decoded by mcap-ros2-support, in log-time order, by topic."""
    with path.open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        types = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        qos = {c.topic: c.metadata.get("offered_qos_profiles", "") for c in summary.channels.values()}
        topics: dict[str, list[Read]] = {}
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            topics.setdefault(channel.topic, []).append(Read(message.log_time, decoded))
    return Recorded(types, qos, topics)


def yaw_of(q: Any) -> float:
    assert q.x == 0.0 and q.y == 0.0
    return 2 * math.atan2(q.z, q.w)


def same_angle(a: float, b: float, tol: float = 1e-9) -> bool:
    return abs(math.remainder(a - b, 2 * math.pi)) < tol


def compose(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float, float]:
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]


def transform_pose(t: Any) -> tuple[float, float, float]:
    tr = t.transform.translation
    return tr.x, tr.y, yaw_of(t.transform.rotation)


def check_latched(qos_text: str) -> None:
    (profile,) = yaml.safe_load(qos_text)
    assert profile["durability"] == 1  # rmw's TRANSIENT_LOCAL
    assert profile["reliability"] == 1  # RELIABLE
    assert profile["depth"] == 1


# --- track --bag --record ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tracked(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Recorded, dict[str, Any], Path]]:
    out = tmp_path_factory.mktemp("track") / "run.mcap"
    result = CliRunner().invoke(
        app, ["track", str(DEPOT_YAML), "--bag", str(BAG), *FAST, "--record", str(out), "--json"]
    )
    assert result.exit_code in (0, 1), result.output
    yield read_mcap(out), json.loads(result.stdout), out


def test_track_recording_has_every_topic_with_its_type(tracked: tuple[Recorded, dict[str, Any], Path]) -> None:
    recorded, _, _ = tracked
    assert recorded.types == TYPES
    check_latched(recorded.qos["/map"])
    check_latched(recorded.qos["/tf_static"])
    assert recorded.qos["/scan"] == ""  # the player's default QoS


def test_track_map_is_the_occupancy_map(tracked: tuple[Recorded, dict[str, Any], Path]) -> None:
    recorded, _, _ = tracked
    (only,) = recorded.topics["/map"]
    grid = only.msg
    occupancy = load_occupancy(DEPOT_YAML)
    assert grid.header.frame_id == "map"
    assert (grid.info.width, grid.info.height) == (occupancy.width, occupancy.height)
    assert grid.info.resolution == pytest.approx(occupancy.resolution)
    origin = grid.info.origin
    assert (origin.position.x, origin.position.y) == pytest.approx((occupancy.frame.x, occupancy.frame.y))
    assert same_angle(yaw_of(origin.orientation), occupancy.frame.yaw)
    data = np.array(grid.data, dtype=np.int64).reshape(occupancy.height, occupancy.width)
    for row in (0, occupancy.height // 2, occupancy.height - 1):  # row 0 of the data is the image's bottom
        expected = [{0: 0, 1: 100, 2: -1}[int(v)] for v in occupancy.pixels[occupancy.height - 1 - row]]
        assert data[row].tolist() == expected
    assert {0, 100, -1} == set(np.unique(data).tolist())


def test_track_scans_and_odometry_are_the_bags(tracked: tuple[Recorded, dict[str, Any], Path]) -> None:
    recorded, _, _ = tracked
    bag = read_recording(BAG)
    scans = recorded.topics["/scan"]
    assert len(scans) == len(bag.scans) > 10
    for read, original in zip(scans, bag.scans, strict=True):
        msg = read.msg
        assert msg.header.frame_id == bag.laser_frame
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == original.stamp == read.log_time
        assert msg.angle_min == pytest.approx(original.angle_min, abs=1e-6)
        assert msg.angle_increment == pytest.approx(original.angle_increment, abs=1e-7)
        assert np.array_equal(np.asarray(msg.ranges), original.ranges.astype(np.float32), equal_nan=True)
    odom = recorded.topics["/odom"]
    assert len(odom) == len(bag.odom_stamps)
    last = odom[-1].msg
    assert (last.header.frame_id, last.child_frame_id) == ("odom", bag.base_frame)
    p = last.pose.pose
    assert (p.position.x, p.position.y) == pytest.approx(tuple(bag.odom_poses[-1, :2]))
    assert same_angle(yaw_of(p.orientation), bag.odom_poses[-1, 2])
    (static,) = recorded.topics["/tf_static"]
    (mount,) = static.msg.transforms
    assert (mount.header.frame_id, mount.child_frame_id) == (bag.base_frame, bag.laser_frame)
    assert transform_pose(mount)[:2] == pytest.approx(bag.mount[:2])


def test_track_belief_and_pose_follow_the_updates(tracked: tuple[Recorded, dict[str, Any], Path]) -> None:
    recorded, answer, _ = tracked
    timeline = answer["timeline"]
    beliefs = recorded.topics["/beliefloc/belief"]
    assert [b.log_time for b in beliefs] == [u["stamp"] for u in timeline]
    for read in beliefs:
        assert read.msg.header.frame_id == "map"
        assert 0 < len(read.msg.poses) <= 200
    cells = recorded.topics["/beliefloc/belief_cells"]
    assert len(cells) == len(timeline)
    (marker,) = cells[-1].msg.markers
    assert marker.type == 6 and marker.ns == "belief" and marker.header.frame_id == "map"
    alphas = [c.a for c in marker.colors]
    assert len(alphas) == len(marker.points) > 0
    assert max(alphas) == pytest.approx(1.0) and min(alphas) > 0
    # the final /beliefloc/pose is the reported pose, covariance and all
    final = recorded.topics["/beliefloc/pose"][-1].msg
    pose = answer["pose"]
    assert final.header.frame_id == "map"
    assert (final.pose.pose.position.x, final.pose.pose.position.y) == pytest.approx((pose["x"], pose["y"]))
    assert same_angle(yaw_of(final.pose.pose.orientation), pose["yaw"])
    assert list(final.pose.covariance) == pytest.approx(pose["covariance"])
    # an intermediate update's pose is the timeline's
    if len(timeline) > 1:
        first = recorded.topics["/beliefloc/pose"][0]
        assert first.log_time == timeline[0]["stamp"]
        assert first.msg.pose.pose.position.x == pytest.approx(timeline[0]["x"])


def test_track_map_to_odom_puts_the_base_at_the_updates_pose(tracked: tuple[Recorded, dict[str, Any], Path]) -> None:
    recorded, answer, _ = tracked
    bag = read_recording(BAG)
    update = answer["timeline"][-1]
    map_odom = [
        t
        for r in recorded.topics["/tf"]
        for t in r.msg.transforms
        if (t.header.frame_id, t.child_frame_id) == ("map", "odom")
    ]
    assert len(map_odom) == len(answer["timeline"])
    odom = bag.odometry_at(np.array([update["stamp"]]))[0]
    x, y, yaw = compose(transform_pose(map_odom[-1]), (float(odom[0]), float(odom[1]), float(odom[2])))
    assert (x, y) == pytest.approx((update["x"], update["y"]), abs=1e-9)
    assert same_angle(yaw, update["yaw"])


def test_a_rosbag2_folder_and_a_replaced_file(tmp_path: Path) -> None:
    """Any OUT but OUT.mcap is a rosbag2 folder (metadata.yaml and OUT.mcap); an existing MCAP file
    is replaced."""
    body = messages.pose_array([], "map", 5)
    folder = tmp_path / "run"
    with open_recording(folder) as out:
        out.write("/beliefloc/belief", "geometry_msgs/msg/PoseArray", body, 5)
    assert sorted(p.name for p in folder.iterdir()) == ["metadata.yaml", "run.mcap"]
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["storage_identifier"] == "mcap" and meta["message_count"] == 1
    assert read_mcap(folder / "run.mcap").topics["/beliefloc/belief"][0].log_time == 5
    single = tmp_path / "one.mcap"
    single.write_bytes(b"")
    with open_recording(single) as out:
        out.write("/beliefloc/belief", "geometry_msgs/msg/PoseArray", body, 7)
    assert read_mcap(single).topics["/beliefloc/belief"][0].log_time == 7
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.mcap", "run"]  # no staging folder left


@pytest.mark.parametrize("stop", [KeyboardInterrupt, RuntimeError])
def test_an_interrupted_recording_leaves_nothing(tmp_path: Path, stop: type[BaseException]) -> None:
    for name in ("cut.mcap", "cut"):
        with pytest.raises(stop), open_recording(tmp_path / name) as out:
            out.write("/beliefloc/belief", "geometry_msgs/msg/PoseArray", messages.pose_array([], "map", 1), 1)
            raise stop()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("make", "args", "message"),
    [
        ("dir", ["--record", "{tmp}/out"], "exists; a rosbag2 folder is written new"),
        ("text", ["--record", "{tmp}/out.mcap"], "the file exists and is not an MCAP file"),
        (None, ["--record", "{tmp}/missing/out.mcap"], "does not exist"),
        (None, ["--record", f"{BAG}/inside.mcap"], "is inside"),
    ],
)
def test_bad_track_record_outputs_exit_2_before_any_work(
    tmp_path: Path, runner: CliRunner, make: str | None, args: list[str], message: str
) -> None:
    if make == "dir":
        (tmp_path / "out").mkdir()
    elif make == "text":
        (tmp_path / "out.mcap").write_text("my notes, named .mcap by mistake\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    result = runner.invoke(
        app, ["track", str(DEPOT_YAML), "--bag", str(BAG), *FAST, *(a.replace("{tmp}", str(tmp_path)) for a in args)]
    )
    assert result.exit_code == 2, result.output
    assert message in result.stderr
    assert "Traceback" not in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_record_goes_with_bag(runner: CliRunner, tmp_path: Path) -> None:
    result = runner.invoke(
        app, ["track", str(MAPS / "kitchen.yaml"), "look=nothing", "--record", str(tmp_path / "a.mcap")]
    )
    assert result.exit_code == 2
    assert "--record goes with --bag" in result.stderr


# --- simulate --record FILE.mcap ------------------------------------------------------------------------

CORRIDOR = """
name: corridor
grid: {rows: 1, cols: 4, cell_size: 1.0, headings: 4}
actions:
  forward: {cost: 1, failure: 0.1}
  rotate_cw: {cost: 1, failure: 0.1}
sensors:
  range:
    type: scan
    passive: true
    as_action: false
    beams: [-90, 0, 90]   # left, ahead, right (clockwise from the heading)
    bins: [0.7, 1.5]
  look:                   # the door at one end breaks the corridor's symmetry
    type: look
    passive: true
    as_action: false
    classes: [door]
    range: 0
landmarks:
  - {class: door, cell: [0, 3]}
"""
"""A 4 m x 1 m corridor read by a three-beam laser and a door detector after every move."""


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Recorded, dict[str, Any], Path]]:
    folder = tmp_path_factory.mktemp("simulate")
    map_file = folder / "corridor.yaml"
    map_file.write_text(CORRIDOR)
    out = folder / "episode.mcap"
    result = CliRunner().invoke(
        app, ["simulate", str(map_file), "--seed", "3", "--max-steps", "8", "--record", str(out), "--json"]
    )
    assert result.exit_code in (0, 1), result.output
    episode = json.loads(result.stdout)["episodes"][0]
    yield read_mcap(out), episode, map_file


def _true_poses(recorded: Recorded) -> list[tuple[int, tuple[float, float, float]]]:
    (static,) = recorded.topics["/tf_static"]
    (map_odom,) = static.msg.transforms
    assert (map_odom.header.frame_id, map_odom.child_frame_id) == ("map", "odom")
    out = []
    for read in recorded.topics["/tf"]:
        (t,) = read.msg.transforms
        assert (t.header.frame_id, t.child_frame_id) == ("odom", "base_link")
        out.append((read.log_time, compose(transform_pose(map_odom), transform_pose(t))))
    return out


def test_simulate_recording_topics_and_the_true_pose(simulated: tuple[Recorded, dict[str, Any], Path]) -> None:
    recorded, episode, map_file = simulated
    assert recorded.types == TYPES
    check_latched(recorded.qos["/map"])
    grid = compile_model(load_map(map_file)).grid
    assert grid is not None
    model = compile_model(load_map(map_file))
    poses = _true_poses(recorded)
    assert len(poses) == episode["steps"] + 1  # the start and every step, a second apart
    assert [t for t, _ in poses] == [(n + 1) * 10**9 for n in range(episode["steps"] + 1)]
    for (_, got), name in ((poses[0], episode["start"]), (poses[-1], episode["true_final"])):
        want = state_pose(grid, model.states.index(name))
        assert got[:2] == pytest.approx((want.x, want.y), abs=1e-12)
        assert same_angle(got[2], want.yaw)
    odom = recorded.topics["/odom"]
    assert len(odom) == len(poses)
    assert all(o.msg.child_frame_id == "base_link" and o.msg.header.frame_id == "odom" for o in odom)


def test_simulate_map_is_the_grid_in_a_wall(simulated: tuple[Recorded, dict[str, Any], Path]) -> None:
    recorded, _, _ = simulated
    (only,) = recorded.topics["/map"]
    info = only.msg.info
    assert (info.width, info.height, info.resolution) == (6, 3, 1.0)
    assert (info.origin.position.x, info.origin.position.y) == (-1.0, -1.0)
    assert list(only.msg.data) == [100] * 6 + [100, 0, 0, 0, 0, 100] + [100] * 6


def test_simulate_scans_are_the_bins_read(simulated: tuple[Recorded, dict[str, Any], Path]) -> None:
    """Every step reads the passive laser: the ranges are the middles of the bins the noise-free
    sensor reads from the true pose in the 4 x 1 m box, at REP 103 angles (left is +90 degrees)."""
    recorded, episode, _ = simulated
    scans = recorded.topics["/scan"]
    assert len(scans) == episode["steps"]
    truth = dict(_true_poses(recorded))
    edges = (0.0, 0.7, 1.5)
    for read in scans:
        msg = read.msg
        assert msg.header.frame_id == "base_link"
        assert msg.angle_min == pytest.approx(-math.pi / 2) and msg.angle_increment == pytest.approx(math.pi / 2)
        assert len(msg.ranges) == 3 and msg.range_max == pytest.approx(1.5)
        x, y, yaw = truth[read.log_time]
        for k, got in enumerate(msg.ranges):
            direction = round(math.degrees(yaw + msg.angle_min + k * msg.angle_increment)) % 360
            distance = {0: 4 - x, 90: 1 - y, 180: x, 270: y}[direction]
            w = next((i for i in range(2) if distance <= edges[i + 1] + 1e-9), 2)  # bins are (low, high]
            assert got == (pytest.approx((edges[w] + edges[w + 1]) / 2) if w < 2 else math.inf)


def test_simulate_final_pose_is_the_episodes(simulated: tuple[Recorded, dict[str, Any], Path]) -> None:
    recorded, episode, _ = simulated
    beliefs = recorded.topics["/beliefloc/belief"]
    assert len(beliefs) == episode["steps"] + 1
    assert all(len(b.msg.poses) > 0 for b in beliefs)
    assert len(beliefs[0].msg.poses) == 16  # the uniform start: every state alike
    final = recorded.topics["/beliefloc/pose"][-1].msg
    pose = episode["pose"]
    assert (final.pose.pose.position.x, final.pose.pose.position.y) == pytest.approx((pose["x"], pose["y"]))
    assert same_angle(yaw_of(final.pose.pose.orientation), pose["yaw"])
    assert list(final.pose.covariance) == pytest.approx(pose["covariance"])
    first = beliefs[-1].msg.poses[0]  # the most likely state first
    assert (first.position.x, first.position.y) == pytest.approx((pose["x"], pose["y"]))


def test_simulate_occupancy_map_goes_to_map(tmp_path: Path, runner: CliRunner) -> None:
    out = tmp_path / "depot.mcap"
    result = runner.invoke(
        app, ["simulate", str(MAPS / "depot.yaml"), "--max-steps", "1", "--record", str(out), "--json"]
    )
    assert result.exit_code in (0, 1), result.output
    (only,) = read_mcap(out).topics["/map"]
    occupancy = load_occupancy(DEPOT_YAML)
    assert (only.msg.info.width, only.msg.info.height) == (occupancy.width, occupancy.height)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--record", "x.mcap", "--record-frames", "5"], "--record-frames 5: is for pictures"),
        (["--record", "x.mcap", "--workers", "2"], "--record: draws every step in this process"),
    ],
)
def test_bad_simulate_record_options(tmp_path: Path, runner: CliRunner, args: list[str], message: str) -> None:
    result = runner.invoke(
        app, ["simulate", str(MAPS / "kitchen.yaml"), *[a.replace("x.mcap", str(tmp_path / "x.mcap")) for a in args]]
    )
    assert result.exit_code == 2, result.output
    assert message in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_the_recording_builders_fit_the_message_definitions() -> None:
    """Every builder's body converts to its rosbags type (an unknown field would raise)."""
    from rosbags.typesys import Stores, get_typestore

    from beliefloc.pose import Pose

    store = get_typestore(Stores.ROS2_HUMBLE)
    p = Pose(1.0, 2.0, 0.5)
    bodies = {
        "geometry_msgs/msg/TransformStamped": messages.transform_stamped("map", "odom", p, 3),
        "nav_msgs/msg/Odometry": messages.odometry(p, 3, forward=0.2, turn=-0.1),
        "sensor_msgs/msg/LaserScan": messages.laser_scan(
            "laser",
            3,
            angle_min=-1.0,
            angle_increment=0.5,
            ranges=[1.0, math.inf, math.nan],
            range_min=0.1,
            range_max=8,
        ),
        "nav_msgs/msg/OccupancyGrid": messages.occupancy_grid(0.05, 2, 1, p, [0, 100]),
        "visualization_msgs/msg/MarkerArray": messages.marker_array(
            [messages.cube_list_marker([(0.0, 1.0)], [(1.0, 0.5, 0.0, 0.3)], 0.2, namespace="b")]
        ),
    }
    for msgtype, body in bodies.items():
        typed = messages.to_typed(store, msgtype, body)
        back = store.deserialize_cdr(store.serialize_cdr(typed, msgtype), msgtype)
        assert type(back).__name__ == type(typed).__name__
    scan = messages.to_typed(store, "sensor_msgs/msg/LaserScan", bodies["sensor_msgs/msg/LaserScan"])
    assert scan.angle_max == pytest.approx(0.0)  # the last of three beams
    tf = messages.to_typed(
        store, "tf2_msgs/msg/TFMessage", messages.tf_message([bodies["geometry_msgs/msg/TransformStamped"]])
    )
    assert tf.transforms[0].transform.rotation.z == pytest.approx(math.sin(0.25))


def test_sigterm_while_recording_leaves_nothing(tmp_path: Path) -> None:
    """A run killed by SIGTERM (a scheduler's stop) mid-recording leaves no staging folder."""
    import os
    import signal
    import subprocess
    import sys

    script = (
        "import os, signal, sys\n"
        "from pathlib import Path\n"
        "from beliefloc.recordings.record import open_recording\n"
        "from beliefloc.ros import messages\n"
        "with open_recording(Path(sys.argv[1])) as out:\n"
        "    out.write('/b', 'geometry_msgs/msg/PoseArray', messages.pose_array([], 'map', 1), 1)\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)}
    done = subprocess.run([sys.executable, "-c", script, str(tmp_path / "run.mcap")], env=env, check=False)
    assert done.returncode == -signal.SIGTERM
    assert list(tmp_path.iterdir()) == []


def test_likely_states_most_probable_first_and_a_spread_sample_of_a_flat_belief() -> None:
    from beliefloc.recordings.record import likely_states

    assert likely_states(np.array([0.5, 0.001, 0.3, 0.199])).tolist() == [0, 2, 3]  # 0.001 < 1 % of 0.5
    assert likely_states(np.array([0.25, 0.25, 0.5])).tolist() == [2, 0, 1]  # ties in index order
    flat = np.full(10_000, 1.0)
    flat[7] = 50.0  # one state far more likely than the rest
    picked = likely_states(flat, limit=200)
    assert 0 < picked.size <= 200 and len(set(picked.tolist())) == picked.size
    assert picked[0] == 7
    assert picked.min() < 1000 and picked.max() > 9000  # spread over the whole belief, not its first states
    assert likely_states(flat, limit=200).tolist() == picked.tolist()  # the same belief, the same poses


def test_shading_keeps_the_whole_belief_drawn_within_the_limit() -> None:
    from beliefloc.recordings.record import BeliefStates, shading

    gx, gy = np.meshgrid(np.arange(100) * 0.1 + 0.05, np.arange(60) * 0.1 + 0.05)
    n = gx.size
    mass = np.full(n, 1.0 / n)

    def states(m: np.ndarray) -> BeliefStates:
        return BeliefStates(gx.ravel(), gy.ravel(), np.zeros(n), m, gx.ravel(), gy.ravel(), m, 0.1)

    coarse = shading(states(mass), limit=2000)  # 6000 cells: 2 x 2 blocks (1500 squares)
    assert coarse.side == pytest.approx(0.2) and coarse.x.size == 1500
    assert coarse.mass.sum() == pytest.approx(1.0)
    assert (coarse.x.min(), coarse.x.max()) == pytest.approx((0.1, 9.9))
    assert (coarse.y.min(), coarse.y.max()) == pytest.approx((0.1, 5.9))
    peaked = mass * 1e-6
    peaked[[5, 17, 900]] = [0.5, 0.3, 0.2]
    fine = shading(states(peaked), limit=2000)  # three cells hold nearly all: the cells themselves
    assert fine.side == pytest.approx(0.1)
    assert fine.x.tolist() == pytest.approx(gx.ravel()[[5, 17, 900]].tolist())
    assert fine.mass.tolist() == pytest.approx([0.5, 0.3, 0.2])


def test_a_recorded_folder_tracks_to_the_same_answer(
    tmp_path: Path, runner: CliRunner, tracked: tuple[Recorded, dict[str, Any], Path]
) -> None:
    """The rosbag2 folder ``--record DIR`` writes is a recording ``track --bag`` reads: the same scans,
    odometry and laser mount give the same run."""
    _, answer, _ = tracked
    folder = tmp_path / "again"
    first = runner.invoke(app, ["track", str(DEPOT_YAML), "--bag", str(BAG), *FAST, "--record", str(folder)])
    assert first.exit_code in (0, 1), first.output
    assert (folder / "metadata.yaml").is_file() and (folder / "again.mcap").is_file()
    second = runner.invoke(app, ["track", str(DEPOT_YAML), "--bag", str(folder), *FAST, "--json"])
    assert second.exit_code in (0, 1), second.output
    replayed = json.loads(second.stdout)
    assert replayed["localized"] == answer["localized"]
    assert replayed["pose"]["x"] == pytest.approx(answer["pose"]["x"], abs=1e-6)
    assert replayed["pose"]["y"] == pytest.approx(answer["pose"]["y"], abs=1e-6)
    assert [u["stamp"] for u in replayed["timeline"]] == [u["stamp"] for u in answer["timeline"]]
