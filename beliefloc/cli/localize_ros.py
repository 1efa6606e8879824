"""``localize --rosbridge``: the options of the live link and the session around it
(:mod:`beliefloc.ros.bridge`): connect, localize, publish, and stop the robot however it ends."""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Annotated, Any
from urllib.parse import urlsplit

import typer

from beliefloc.cli.options import parse_laser_pose
from beliefloc.errors import ReplyError, UsageError

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.model import Model
    from beliefloc.robots.belief_filter import BeliefFilter
    from beliefloc.robots.localize import Localization, LocalizeStep
    from beliefloc.robots.readings import ReadingBinner
    from beliefloc.ros.bridge import BridgeSettings
    from beliefloc.simulation.strategies import PlannerSettings

PANEL = "Live link (--rosbridge)"

RosbridgeOption = Annotated[
    str | None,
    typer.Option(
        "--rosbridge",
        metavar="ws://HOST:PORT",
        help="Drive a ROS robot through rosbridge_server instead of the line protocol: its scan and odometry topics "
        "in, /cmd_vel, the belief and /initialpose out (docs/rosbridge.md; needs pip install 'beliefloc[ros]').",
        rich_help_panel=PANEL,
        show_default=False,
    ),
]
ScanTopicOption = Annotated[
    str, typer.Option("--scan-topic", metavar="TOPIC", help="sensor_msgs/LaserScan topic.", rich_help_panel=PANEL)
]
OdomTopicOption = Annotated[
    str, typer.Option("--odom-topic", metavar="TOPIC", help="nav_msgs/Odometry topic.", rich_help_panel=PANEL)
]
CmdVelTopicOption = Annotated[
    str,
    typer.Option(
        "--cmd-vel-topic", metavar="TOPIC", help="geometry_msgs/Twist topic the base obeys.", rich_help_panel=PANEL
    ),
]
DetectionsTopicOption = Annotated[
    str | None,
    typer.Option(
        "--detections-topic",
        metavar="TOPIC",
        help="Where a Look sensor's detections come from (needed when the map has one).",
        rich_help_panel=PANEL,
        show_default=False,
    ),
]
DetectionsTypeOption = Annotated[
    str,
    typer.Option(
        "--detections-type",
        metavar="TYPE",
        help="vision_msgs/Detection2DArray (each detection's best class) or std_msgs/String (class names separated by "
        "commas or spaces).",
        rich_help_panel=PANEL,
    ),
]
LaserFrameOption = Annotated[
    str | None,
    typer.Option(
        "--laser-frame",
        metavar="FRAME",
        help="The scan's frame_id, with --laser-pose. Without both, the scan must be in the odometry's child frame.",
        rich_help_panel=PANEL,
        show_default=False,
    ),
]
LaserPoseOption = Annotated[
    str | None,
    typer.Option(
        "--laser-pose",
        metavar="X,Y,YAW",
        help="The laser's pose on the base (metres, metres, radians), with --laser-frame.",
        rich_help_panel=PANEL,
        show_default=False,
    ),
]
RobotRadiusOption = Annotated[
    float | None,
    typer.Option(
        "--robot-radius",
        metavar="METRES",
        min=0.01,
        max=10.0,
        help="The base's radius for the obstacle stop [default: the map's grid.robot_radius, else 0.2].",
        rich_help_panel=PANEL,
        show_default=False,
    ),
]
MarginOption = Annotated[
    float,
    typer.Option(
        "--margin",
        metavar="METRES",
        min=0.0,
        max=10.0,
        help="A drive stops when the scan shows an obstacle nearer than radius + margin ahead.",
        rich_help_panel=PANEL,
    ),
]
MaxSpeedOption = Annotated[
    float, typer.Option("--max-speed", metavar="M/S", min=0.01, max=5.0, help="Fastest drive.", rich_help_panel=PANEL)
]
MaxTurnOption = Annotated[
    float,
    typer.Option("--max-turn-speed", metavar="RAD/S", min=0.05, max=10.0, help="Fastest turn.", rich_help_panel=PANEL),
]
MotionTimeoutOption = Annotated[
    float,
    typer.Option(
        "--motion-timeout",
        metavar="SECONDS",
        min=0.01,
        max=3600.0,
        help="Longest one motion may take; a base that moved under 10% of it by then is stuck (exit 2).",
        rich_help_panel=PANEL,
    ),
]
SettleOption = Annotated[
    float,
    typer.Option(
        "--settle",
        metavar="SECONDS",
        min=0.0,
        max=60.0,
        help="Wait after a motion before reading the sensors.",
        rich_help_panel=PANEL,
    ),
]
RosTimeoutOption = Annotated[
    float,
    typer.Option(
        "--ros-timeout",
        metavar="SECONDS",
        min=0.01,
        max=3600.0,
        help="Longest wait for the connection and for a topic's next message (exit 2 after it).",
        rich_help_panel=PANEL,
    ),
]


def bridge_settings(
    url: str | None,
    *,
    scan_topic: str,
    odom_topic: str,
    cmd_vel_topic: str,
    detections_topic: str | None,
    detections_type: str,
    laser_frame: str | None,
    laser_pose: str | None,
    robot_radius: float | None,
    margin: float,
    max_speed: float,
    max_turn: float,
    motion_timeout: float,
    settle: float,
    ros_timeout: float,
) -> BridgeSettings | None:
    """The options as :class:`~beliefloc.ros.bridge.BridgeSettings`, checked together (before the
    map is read); None without ``--rosbridge``, when a link option given is a usage error."""
    given = {
        "--scan-topic": scan_topic != "/scan",
        "--odom-topic": odom_topic != "/odom",
        "--cmd-vel-topic": cmd_vel_topic != "/cmd_vel",
        "--detections-topic": detections_topic is not None,
        "--laser-frame": laser_frame is not None,
        "--laser-pose": laser_pose is not None,
        "--robot-radius": robot_radius is not None,
    }
    if url is None:
        used = [name for name, set_ in given.items() if set_]
        if used:
            raise UsageError(f"{used[0]} is an option of the live link: give --rosbridge ws://HOST:PORT too")
        return None
    from beliefloc.ros.bridge import BridgeSettings
    from beliefloc.ros.motion_control import MotionLimits
    from beliefloc.ros.sensors import DETECTION_TYPES

    if urlsplit(url).scheme not in ("ws", "wss"):
        raise UsageError(f"--rosbridge {url!r}: give rosbridge's websocket as ws://HOST:PORT, e.g. ws://robot:9090")
    if (laser_frame is None) != (laser_pose is None):
        raise UsageError(
            "--laser-frame and --laser-pose go together: the frame the scan is in and where that frame sits on the "
            "base (without both, the scan must be in the base frame)"
        )
    if detections_type not in DETECTION_TYPES:
        raise UsageError(f"--detections-type {detections_type!r}: one of {', '.join(DETECTION_TYPES)}")
    limits = MotionLimits(
        max_speed=max_speed,
        max_turn=max_turn,
        min_speed=min(MotionLimits.min_speed, max_speed),
        min_turn=min(MotionLimits.min_turn, max_turn),
    )
    return BridgeSettings(
        scan_topic=scan_topic,
        odom_topic=odom_topic,
        cmd_vel_topic=cmd_vel_topic,
        detections_topic=detections_topic,
        detections_type=detections_type,
        laser_frame=laser_frame.lstrip("/") if laser_frame is not None else None,
        laser_mount=parse_laser_pose(laser_pose) if laser_pose is not None else (0.0, 0.0, 0.0),
        robot_radius=robot_radius if robot_radius is not None else BridgeSettings.robot_radius,
        margin=margin,
        limits=limits,
        motion_timeout=motion_timeout,
        settle=settle,
        timeout=ros_timeout,
    )


def with_map_radius(settings: BridgeSettings | None, option: float | None, map_radius: float | None) -> BridgeSettings:
    """``settings`` with the map's ``grid.robot_radius`` for the obstacle stop, unless --robot-radius
    gave one."""
    import dataclasses

    assert settings is not None
    if option is None and map_radius is not None:
        return dataclasses.replace(settings, robot_radius=float(map_radius))
    return settings


@contextmanager
def _signals_stop() -> Iterator[None]:
    """Ctrl-C and SIGTERM end the session as an error (the robot is stopped on the way out)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupted(signum: int, _frame: Any) -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the stop on the way out is not interrupted
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        raise ReplyError(f"interrupted by {signal.Signals(signum).name} before localization ended")

    previous = {sig: signal.signal(sig, interrupted) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def run(
    url: str,
    settings: BridgeSettings,
    model: Model,
    start: np.ndarray,
    binner: ReadingBinner,
    planner: PlannerSettings,
    max_steps: int,
    on_step: Callable[[LocalizeStep], None],
    belief_filter: BeliefFilter | None = None,
) -> Localization:
    """Connect, localize the robot, publish the belief at every step and ``/initialpose`` when
    localized; the robot is stopped whatever happens. The outcome's result goes on stdout."""
    import json

    from beliefloc.robots.line_protocol import result_message
    from beliefloc.robots.localize import localize
    from beliefloc.ros.bridge import RosbridgeRobot, RoslibpyLink, check_map, stopped

    check_map(binner, settings)  # before connecting: a map the link cannot drive is a usage error
    with _signals_stop():
        link = RoslibpyLink(url, settings.timeout)
        try:
            robot = RosbridgeRobot(binner, link, settings)
            with stopped(robot):

                def step(done: LocalizeStep) -> None:
                    robot.publish_belief(model, done.belief)
                    on_step(done)

                robot.publish_belief(model, start)
                outcome = localize(
                    model,
                    start,
                    robot,
                    binner,
                    settings=planner,
                    max_steps=max_steps,
                    on_step=step,
                    belief_filter=belief_filter,
                )
                estimate = outcome.pose_estimate(model) if outcome.localized else None
                if estimate is not None:
                    robot.publish_initial_pose(estimate)
        finally:
            link.close()
    sys.stdout.write(json.dumps(result_message(outcome, model), allow_nan=False) + "\n")
    return outcome
