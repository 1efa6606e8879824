"""Issue 29, the live link: ``localize --rosbridge`` against a fake rosbridge server
(tests/fake_rosbridge.py) with the continuous simulated robot behind it, and the link's pure parts
(message parsing, beams by angle, the motion controller, the obstacle stop)."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.errors import ReplyError, UsageError
from beliefloc.model import Model
from beliefloc.pose import nonnegative_covariance, state_pose
from beliefloc.robots.readings import ReadingBinner
from beliefloc.ros.bridge import BridgeSettings, check_map, likely_states
from beliefloc.ros.motion_control import Goal, MotionLimits, obstacle_ahead, velocity
from beliefloc.ros.sensors import Scan, base_points, beam_ranges, parse_detections, parse_odometry, parse_scan

from .conftest import MAPS, ROOT

pytest.importorskip("websockets")
pytest.importorskip("roslibpy")

from .fake_rosbridge import FakeRosbridge, Faults, kitchen_server

ZERO = {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}


def _scan_body(**changes: Any) -> dict[str, Any]:
    body: dict[str, Any] = {
        "header": {"stamp": {"sec": 3, "nanosec": 5}, "frame_id": "base_link"},
        "angle_min": -math.pi,
        "angle_max": math.pi / 2,
        "angle_increment": math.pi / 2,
        "time_increment": 0.0,
        "scan_time": 0.1,
        "range_min": 0.1,
        "range_max": 10.0,
        "ranges": [1.0, 2.0, 3.0, None],  # behind, right, ahead, left
        "intensities": [],
    }
    body.update(changes)
    return body


# --- messages in ---------------------------------------------------------------------------------


def test_a_scan_is_read_with_null_as_no_return() -> None:
    scan = parse_scan(_scan_body(), "/scan")
    assert scan.frame_id == "base_link" and scan.stamp_ns == 3_000_000_005
    assert scan.ranges == (1.0, 2.0, 3.0, math.inf)


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"ranges": []}, "'ranges'"),
        ({"ranges": [1.0, "x"]}, "ranges\\[1\\]"),
        ({"angle_increment": None}, "'angle_increment'"),
        ({"header": {"frame_id": "a"}}, "'header.stamp'"),
    ],
)
def test_a_bad_scan_is_refused_naming_the_field(change: dict[str, Any], field: str) -> None:
    with pytest.raises(ReplyError, match=f"topic /scan: .*{field}"):
        parse_scan(_scan_body(**change), "/scan")


def test_beams_are_picked_by_angle_in_the_laser_frame() -> None:
    scan = parse_scan(_scan_body(), "/scan")
    ahead, left, right, behind = 0.0, math.pi / 2, -math.pi / 2, math.pi
    assert beam_ranges(scan, [ahead, left, right, behind], (0.0, 0.0, 0.0), "/scan") == [3.0, None, 2.0, 1.0]
    # a laser turned +90° on the base: its 0 rad looks left, so the base's "ahead" is its -90°
    assert beam_ranges(scan, [ahead, left], (0.0, 0.0, math.pi / 2), "/scan") == [2.0, 3.0]
    # a laser 0.1 m ahead of the centre: a wall ahead is 0.1 m further from the centre, one behind nearer
    assert beam_ranges(scan, [ahead, behind], (0.1, 0.0, 0.0), "/scan") == pytest.approx([3.1, 0.9])


def test_returns_outside_the_range_limits_follow_rep_117() -> None:
    scan = parse_scan(_scan_body(ranges=[0.05, 20.0, -math.inf, math.nan]), "/scan")
    got = beam_ranges(scan, [math.pi, -math.pi / 2, 0.0, math.pi / 2], (0.0, 0.0, 0.0), "/scan")
    assert got == [0.0, None, 0.0, None]  # too near: a wall right there; beyond range_max or NaN: no wall


def test_a_beam_outside_the_scan_is_refused_with_the_scan_s_coverage() -> None:
    scan = parse_scan(_scan_body(angle_min=-0.5, angle_increment=0.5, ranges=[1.0, 1.0, 1.0]), "/scan")
    with pytest.raises(ReplyError, match=r"beam at 90° .* outside the scan, which covers -28\.65° to 28\.65°"):
        beam_ranges(scan, [math.pi / 2], (0.0, 0.0, 0.0), "/scan")


def test_odometry_gives_the_yaw_of_its_quaternion() -> None:
    yaw = 2.5
    body = {
        "header": {"stamp": {"secs": 1, "nsecs": 2}, "frame_id": "/odom"},  # ROS 1 field names
        "child_frame_id": "base_footprint",
        "pose": {"pose": {"position": {"x": 1.0, "y": -2.0, "z": 0.0},
                          "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}},
    }  # fmt: skip
    odometry = parse_odometry(body, "/odom")
    assert (odometry.frame_id, odometry.child_frame_id, odometry.stamp_ns) == ("odom", "base_footprint", 1_000_000_002)
    assert odometry.pose == pytest.approx((1.0, -2.0, yaw))
    body["pose"]["pose"]["orientation"] = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}
    with pytest.raises(ReplyError, match=r"topic /odom: 'pose\.pose\.orientation' is not a unit quaternion"):
        parse_odometry(body, "/odom")


def test_detections_in_both_shapes() -> None:
    vision = {
        "detections": [
            {"results": [{"hypothesis": {"class_id": "chair", "score": 0.3}},
                         {"hypothesis": {"class_id": "screen", "score": 0.8}}]},
            {"results": [{"id": "chair", "score": 0.9}]},  # vision_msgs before 3.0
            {"results": []},
        ]
    }  # fmt: skip
    assert parse_detections(vision, "/d", "vision_msgs/Detection2DArray") == ["screen", "chair"]
    assert parse_detections({"data": "chair, screen chair"}, "/d", "std_msgs/String") == ["chair", "screen"]
    assert parse_detections({"data": ""}, "/d", "std_msgs/String") == []
    with pytest.raises(ReplyError, match=r"topic /d: 'detections\[0\]\.results'"):
        parse_detections({"detections": [{}]}, "/d", "vision_msgs/Detection2DArray")


# --- the controller ------------------------------------------------------------------------------


def test_the_controller_slows_down_near_the_goal_and_stops_there() -> None:
    limits = MotionLimits()
    drive = Goal("drive", 1.0)
    assert velocity(drive, (0.0, 0.0, 0.0), limits) == (limits.max_speed, 0.0)
    slow = velocity(drive, (1.0 - 1.5 * limits.tolerance, 0.0, 0.0), limits)
    assert slow is not None and slow[0] == limits.min_speed
    assert velocity(drive, (1.0 - limits.tolerance / 2, 0.0, 0.0), limits) is None
    assert velocity(drive, (1.2, 0.0, 0.0), limits) is None  # an overshoot is not driven back
    _, hold = velocity(drive, (0.5, 0.0, 0.1), limits) or (0.0, 0.0)
    assert hold < 0  # drifted left: steer right
    back = velocity(Goal("drive", -1.2), (0.0, 0.0, 0.0), limits)
    assert back is not None and back[0] == -limits.max_speed
    turn = velocity(Goal("turn", -math.pi / 2), (0.0, 0.0, -0.2), limits)
    assert turn is not None and turn[0] == 0.0 and turn[1] == -limits.max_turn


@pytest.mark.parametrize(("kind", "amount"), [("drive", 1.2), ("drive", -0.25), ("turn", math.pi / 2), ("turn", -2.0)])
def test_the_controller_reaches_its_goal_on_a_lagging_base(kind: str, amount: float) -> None:
    """An oracle: a base that obeys each command one step late, integrated at 20 Hz, ends within
    the tolerance plus one step of the slowest speed."""
    limits = MotionLimits()
    goal = Goal(kind, amount)
    x = yaw = 0.0
    pending = (0.0, 0.0)
    dt = 0.05
    for _ in range(2000):
        command = velocity(goal, (x, 0.0, yaw), limits)
        if command is None:
            break
        x += pending[0] * dt
        yaw += pending[1] * dt
        pending = command
    else:
        pytest.fail("the controller never finished")
    done = x if kind == "drive" else yaw
    slack = (limits.tolerance + 2 * limits.min_speed * dt) if kind == "drive" else (
        limits.turn_tolerance + 2 * limits.min_turn * dt)  # fmt: skip
    assert abs(done - amount) <= slack


def test_the_obstacle_stop_looks_in_the_corridor_the_base_drives_into() -> None:
    scan = Scan("base_link", 0, 0.0, math.pi / 2, 0.05, 10.0, (0.25, 0.25, 0.5, 0.25))  # ahead, left, behind, right
    points = base_points(scan, (0.0, 0.0, 0.0))
    assert obstacle_ahead(points, forward=True, radius=0.2, margin=0.1) == pytest.approx(0.25)
    assert obstacle_ahead(points, forward=False, radius=0.2, margin=0.1) is None  # 0.5 m behind: clear
    assert obstacle_ahead(points, forward=False, radius=0.2, margin=0.35) == pytest.approx(0.5)
    # the returns at the sides (0.25 m left and right) are outside a 0.2 m base's corridor
    assert obstacle_ahead([(0.0, 0.25), (0.1, -0.25)], forward=True, radius=0.2, margin=0.1) is None


def test_the_belief_s_pose_array_holds_its_likeliest_states() -> None:
    belief = np.array([0.05, 0.6, 0.3, 0.05])
    assert list(likely_states(belief, mass=0.9)) == [1, 2]
    assert list(likely_states(belief, mass=0.99)) == [1, 2, 0, 3]
    assert list(likely_states(belief, mass=0.99, limit=2)) == [1, 2]


# --- maps the link cannot drive ------------------------------------------------------------------


def _binner(name: str) -> ReadingBinner:
    smap = load_map(MAPS / f"{name}.yaml")
    return ReadingBinner(smap, compile_model(smap))


def test_maps_the_link_cannot_drive_are_refused_before_connecting() -> None:
    with pytest.raises(UsageError, match=r"1 heading.*up/down/left/right"):
        check_map(_binner("window-2x2"), BridgeSettings(detections_topic="/d"))
    with pytest.raises(UsageError, match=r"8 heading.*diagonal"):
        check_map(_binner("hallway"), BridgeSettings(detections_topic="/d"))
    with pytest.raises(UsageError, match="Look sensor \\('look'\\): give --detections-topic"):
        check_map(_binner("kitchen"), BridgeSettings())


# --- a session against the fake rosbridge --------------------------------------------------------


@pytest.fixture(scope="module")
def kitchen() -> tuple[Model, ReadingBinner]:
    smap = load_map(MAPS / "kitchen.yaml")
    model = compile_model(smap)
    return model, ReadingBinner(smap, model)


@pytest.fixture
def server(kitchen: tuple[Model, ReadingBinner], request: pytest.FixtureRequest) -> Iterator[FakeRosbridge]:
    """The kitchen's robot in the centre cell facing east (state 1,1,1); ``faults`` and the
    detection form from the test's parameters (indirect)."""
    model, binner = kitchen
    options = getattr(request, "param", {})
    start = state_pose(model.grid, model.states.index(options.get("state", "1,1,1")))  # type: ignore[arg-type]
    fake = kitchen_server(0, (start.x, start.y, start.yaw), binner, faults=options.get("faults"),
                          detection_form=options.get("form", "vision"))  # fmt: skip
    with fake:
        yield fake


FAST = ["--settle", "0.05", "--ros-timeout", "2", "--motion-timeout", "5", "--quiet"]


def _localize(runner: Any, fake: FakeRosbridge, *extra: str) -> Any:
    from beliefloc.cli.app import app

    args = ["localize", str(MAPS / "kitchen.yaml"), "--rosbridge", fake.url, "--detections-topic", "/detections"]
    return runner.invoke(app, [*args, *FAST, *extra])


def _true_state(model: Model, pose: np.ndarray) -> str:
    """The state whose cell holds the robot's true pose and whose heading is nearest its yaw."""
    assert model.grid is not None
    poses = [state_pose(model.grid, s) for s in range(model.n_states)]
    x, y, yaw = (float(v) for v in pose)
    best = min(
        range(model.n_states),
        key=lambda s: (
            round(max(abs(poses[s].x - x), abs(poses[s].y - y)) / model.grid.cell_size),
            abs(math.remainder(poses[s].yaw - yaw, 2 * math.pi)),
        ),
    )
    return model.states.name(best)


def _assert_stopped(fake: FakeRosbridge) -> None:
    commands = fake.messages("/cmd_vel")
    assert commands and commands[-1] == ZERO
    assert fake.velocity == (0.0, 0.0)


@pytest.mark.parametrize(
    "server",
    [{"state": "1,1,1"}, {"state": "0,2,2", "form": "string"}],
    indirect=True,
    ids=["vision-detections", "string-detections"],
)
def test_a_session_localizes_the_simulated_robot_and_publishes_its_pose(
    runner: Any, server: FakeRosbridge, kitchen: tuple[Model, ReadingBinner]
) -> None:
    import json

    model, _ = kitchen
    extra = ["--detections-type", "std_msgs/String"] if server.detection_form == "string" else []
    result = _localize(runner, server, *extra)
    assert result.exit_code == 0, result.output
    outcome = json.loads(result.stdout.strip().splitlines()[-1])
    truth = _true_state(model, server.robot.pose)
    assert outcome["localized"] and outcome["state"] == truth
    [initial] = server.messages("/initialpose")
    expected = state_pose(model.grid, model.states.index(truth))  # type: ignore[arg-type]
    got = initial["pose"]["pose"]
    assert (got["position"]["x"], got["position"]["y"]) == pytest.approx((expected.x, expected.y))
    assert 2 * math.atan2(got["orientation"]["z"], got["orientation"]["w"]) == pytest.approx(expected.yaw, abs=1e-9)
    assert initial["header"]["frame_id"] == "map" and initial["header"]["stamp"]["sec"] >= 1000  # the robot's clock
    assert initial["pose"]["covariance"] == pytest.approx(
        nonnegative_covariance(tuple(outcome["pose"]["covariance"])), abs=1e-12
    )  # the result's, with no negative entry: Nav2 Rolling's AMCL refuses one
    beliefs = server.messages("/beliefloc/belief")
    assert len(beliefs) == outcome["steps"] + 1  # the start, then one a step
    assert len(beliefs[0]["poses"]) == model.n_states  # uniform: every state is as likely
    assert beliefs[-1]["poses"][0]["position"] == got["position"]  # the likeliest first
    _assert_stopped(server)
    subscribed = {op["topic"] for op in server.ops if op["op"] == "subscribe"}
    assert subscribed == {"/scan", "/odom", "/detections"}
    advertised = {(op["topic"], op["type"]) for op in server.ops if op["op"] == "advertise"}
    assert advertised == {
        ("/cmd_vel", "geometry_msgs/Twist"),
        ("/beliefloc/belief", "geometry_msgs/PoseArray"),
        ("/initialpose", "geometry_msgs/PoseWithCovarianceStamped"),
    }


@pytest.mark.parametrize("server", [{"faults": Faults(silent=frozenset({"/scan"}))}], indirect=True)
def test_a_topic_that_never_publishes_ends_the_session_with_the_robot_stopped(
    runner: Any, server: FakeRosbridge
) -> None:
    result = _localize(runner, server, "--ros-timeout", "0.5")
    assert result.exit_code == 2
    assert "topic /scan (sensor_msgs/LaserScan): no message within 0.5 s" in result.output
    assert "is the name right" in result.output and "Traceback" not in result.output
    _assert_stopped(server)


@pytest.mark.parametrize("server", [{"faults": Faults(stuck=True)}], indirect=True)
def test_a_stuck_base_ends_the_session_with_the_robot_stopped(runner: Any, server: FakeRosbridge) -> None:
    result = _localize(runner, server, "--motion-timeout", "0.5")
    assert result.exit_code == 2
    assert "the robot did not move during action" in result.output
    assert "covered 0% of the" in result.output and "--motion-timeout" in result.output
    _assert_stopped(server)


@pytest.mark.parametrize("server", [{"faults": Faults(scan_frame="laser")}], indirect=True)
def test_a_scan_in_another_frame_is_refused(runner: Any, server: FakeRosbridge) -> None:
    result = _localize(runner, server)
    assert result.exit_code == 2
    assert "the scan's frame is 'laser'" in " ".join(result.output.split())
    assert "--laser-frame laser" in result.output
    _assert_stopped(server)
    declared = _localize(runner, server, "--laser-frame", "laser_link", "--laser-pose", "0,0,0")
    assert declared.exit_code == 2 and "--laser-frame says 'laser_link'" in " ".join(declared.output.split())


@pytest.mark.parametrize("server", [{"faults": Faults(drop_after_cmd=5)}], indirect=True)
def test_a_dropped_connection_ends_the_session_and_the_stop_goes_out_after_reconnecting(
    runner: Any, server: FakeRosbridge
) -> None:
    result = _localize(runner, server)
    assert result.exit_code == 2
    text = " ".join(result.output.split())
    assert f"the connection to {server.url} dropped during action" in text
    assert "the robot was told to stop" in text
    assert server.connections == 2  # roslibpy reconnected, and the stop went out on the new connection
    _assert_stopped(server)


def test_a_server_that_is_not_there_is_a_one_paragraph_error(runner: Any) -> None:
    import socket

    from beliefloc.cli.app import app

    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    args = ["localize", str(MAPS / "kitchen.yaml"), "--rosbridge", f"ws://127.0.0.1:{port}"]
    result = runner.invoke(app, [*args, "--detections-topic", "/d", "--ros-timeout", "0.5"])
    assert result.exit_code == 2
    assert f"could not connect to rosbridge at ws://127.0.0.1:{port} within 0.5 s" in result.output


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--rosbridge", "http://robot:9090"], "give rosbridge's websocket as ws://HOST:PORT"),
        (["--rosbridge", "ws://robot:9090", "--laser-frame", "laser"], "--laser-frame and --laser-pose go together"),
        (["--rosbridge", "ws://robot:9090", "--laser-frame", "l", "--laser-pose", "1,2"], "--laser-pose '1,2'"),
        (["--rosbridge", "ws://robot:9090", "--detections-type", "std_msgs/Int8"], "--detections-type"),
        (["--scan-topic", "/base_scan"], "--scan-topic is an option of the live link: give --rosbridge"),
    ],
)
def test_bad_link_options_are_refused(runner: Any, extra: list[str], message: str) -> None:
    from beliefloc.cli.app import app

    result = runner.invoke(app, ["localize", str(MAPS / "kitchen.yaml"), "--detections-topic", "/d", *extra])
    assert result.exit_code == 2
    assert message in " ".join(result.output.split())


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_and_ctrl_c_stop_the_robot_before_exiting(
    kitchen: tuple[Model, ReadingBinner], sig: signal.Signals
) -> None:
    """A real process (signals go to the main thread): a slow drive is under way when the signal
    comes; the process exits 2 with one paragraph, and the last /cmd_vel is the stop."""
    model, binner = kitchen
    start = state_pose(model.grid, model.states.index("1,1,1"))  # type: ignore[arg-type]
    with kitchen_server(0, (start.x, start.y, start.yaw), binner, speedup=1.0) as fake:
        args = ["localize", str(MAPS / "kitchen.yaml"), "--rosbridge", fake.url, "--detections-topic", "/detections",
                "--max-speed", "0.01", "--max-turn-speed", "0.05", *FAST]  # fmt: skip
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        process = subprocess.Popen([sys.executable, "-m", "beliefloc", *args], env=env, stderr=subprocess.PIPE,
                                   stdout=subprocess.PIPE, text=True)  # fmt: skip
        deadline = time.monotonic() + 30
        while not any(c != ZERO for c in fake.messages("/cmd_vel")):
            assert time.monotonic() < deadline and process.poll() is None, "the robot was never driven"
            time.sleep(0.05)
        process.send_signal(sig)
        _, err = process.communicate(timeout=30)
        assert process.returncode == 2, err
        assert f"interrupted by {sig.name} before localization ended" in " ".join(err.split())
        assert "Traceback" not in err
        _assert_stopped(fake)


# --- one action on the live link ----------------------------------------------------------------


def _link_robot(fake: FakeRosbridge, binner: ReadingBinner) -> Any:
    from beliefloc.ros.bridge import RosbridgeRobot, RoslibpyLink

    settings = BridgeSettings(detections_topic="/detections", settle=0.05, timeout=2.0, motion_timeout=5.0)
    return RosbridgeRobot(binner, RoslibpyLink(fake.url, 2.0), settings)


@pytest.mark.parametrize(
    ("server", "action", "moved"),
    [
        ({"state": "1,1,1"}, "forward", (1.2, 0.0, 0.0)),  # east, into the free cell 1,2
        ({"state": "1,1,1"}, "rotate_ccw", (0.0, 0.0, math.pi / 2)),  # east to north
        ({"state": "1,1,1"}, "rotate_cw", (0.0, 0.0, -math.pi / 2)),
        ({"state": "1,1,1"}, "backward", (-1.2, 0.0, 0.0)),
    ],
    indirect=["server"],
)
def test_a_move_is_driven_to_its_goal_on_odometry(
    server: FakeRosbridge, kitchen: tuple[Model, ReadingBinner], action: str, moved: tuple[float, float, float]
) -> None:
    from beliefloc.continuous.motion import relative
    from beliefloc.robots.localize import Command
    from beliefloc.robots.odometry import MotionReport

    model, binner = kitchen
    robot = _link_robot(server, binner)
    try:
        before = server.robot.odometry.copy()
        readings = robot.act(Command(1, model.action(action), None, None))
        assert set(readings) == set()  # the kitchen has no passive sensor
        assert robot.motion_report() == MotionReport(None, False)
        done = relative(before, server.robot.odometry)
        assert done[:2] == pytest.approx(moved[:2], abs=0.03)  # the controller's tolerance and one late step
        assert math.remainder(done[2] - moved[2], 2 * math.pi) == pytest.approx(0.0, abs=math.radians(3))
        _assert_stopped(server)
    finally:
        robot.link.close()


@pytest.mark.parametrize("server", [{"state": "0,1,0"}], indirect=True)  # north, 0.6 m from the north wall
def test_a_drive_stopped_by_an_obstacle_drives_back_and_reports_blocked(
    server: FakeRosbridge, kitchen: tuple[Model, ReadingBinner]
) -> None:
    from beliefloc.robots.localize import Command
    from beliefloc.robots.odometry import MotionReport

    model, binner = kitchen
    robot = _link_robot(server, binner)
    try:
        start = server.robot.pose.copy()
        robot.act(Command(1, model.action("forward"), None, None))
        assert robot.motion_report() == MotionReport(None, True)
        driven = [c["linear"]["x"] for c in server.messages("/cmd_vel")]
        assert max(driven) > 0 and min(driven) < 0  # there, and back
        assert server.robot.pose[:2] == pytest.approx(start[:2], abs=0.03)
        _assert_stopped(server)
        scan = robot.act(Command(2, model.action("scan"), None, None))["scan"]
        assert scan == [pytest.approx(0.6, abs=0.05)]  # the wall, from the cell's centre again
    finally:
        robot.link.close()


class _DeadLink:
    """A link whose connection is gone and does not come back."""

    url = "ws://robot:9090"
    connected = False

    def __init__(self) -> None:
        self.published: list[tuple[str, Any]] = []

    def subscribe(self, topic: str, message_type: str, callback: Any) -> None:
        pass

    def advertise(self, topic: str, message_type: str) -> None:
        pass

    def publish(self, topic: str, body: Any) -> None:
        self.published.append((topic, body))

    def on_connection(self, callback: Any) -> None:
        pass

    def close(self) -> None:
        pass


def test_a_stop_that_cannot_be_sent_is_said_in_the_error(kitchen: tuple[Model, ReadingBinner]) -> None:
    from beliefloc.ros.bridge import RosbridgeRobot, stopped

    _, binner = kitchen
    link = _DeadLink()
    robot = RosbridgeRobot(binner, link, BridgeSettings(detections_topic="/d", timeout=0.1))
    said = r"^topic /odom: gone; the robot could not be told to stop: the connection to ws://robot:9090 did not come"
    with pytest.raises(ReplyError, match=said), stopped(robot):
        raise ReplyError("topic /odom: gone")
    assert link.published == []  # nothing was sent into a dead connection
    with pytest.raises(ReplyError, match=r"^The robot could not be told to stop"), stopped(robot):
        pass


def test_the_initial_pose_published_has_no_negative_covariance_entry(kitchen: tuple[Model, ReadingBinner]) -> None:
    """A pose whose x and y are anti-correlated (a belief along a diagonal) is published to
    /initialpose with that pair made non-negative, as `pose --format ros` writes it: Nav2 Rolling's
    AMCL refuses a negative entry, and the pose would be ignored."""
    from beliefloc.pose import Pose, PoseEstimate
    from beliefloc.ros.bridge import RosbridgeRobot

    _, binner = kitchen
    link = _DeadLink()
    robot = RosbridgeRobot(binner, link, BridgeSettings(detections_topic="/d", timeout=0.1))
    cov = np.zeros((6, 6))
    cov[[0, 1, 5], [0, 1, 5]] = [0.04, 0.05, 0.1]
    cov[0, 1] = cov[1, 0] = -0.03
    robot.publish_initial_pose(PoseEstimate(Pose(1.0, 2.0, 0.5), tuple(cov.ravel()), 3, 0.97))
    [(topic, body)] = link.published
    assert topic == "/initialpose"
    sent = np.array(body["pose"]["covariance"]).reshape(6, 6)
    assert sent.min() >= 0.0
    expected = cov.copy()
    expected[0, 1] = expected[1, 0] = 0.0
    expected[0, 0] += 0.03
    expected[1, 1] += 0.03
    np.testing.assert_allclose(sent, expected, atol=1e-12)
    assert body["pose"]["pose"]["position"]["x"] == pytest.approx(1.0)
