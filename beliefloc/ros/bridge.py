"""The live link: a ROS robot behind ``beliefloc localize``'s robot interface, through rosbridge.

:class:`RosbridgeRobot` is a :class:`~beliefloc.robots.localize.ReadingRobot` (and a
:class:`~beliefloc.robots.odometry.ReportingRobot`), as the line protocol's
:class:`~beliefloc.robots.line_protocol.LineRobot` is, so ``localize``'s loop is the same loop. For
each action it:

1. drives the action's motion (:func:`beliefloc.robots.odometry.motion`: a turn of one heading,
   a straight move of one cell) as ``geometry_msgs/Twist`` on ``/cmd_vel``, closed on the odometry
   topic (:mod:`beliefloc.ros.motion_control`): each odometry message gives the next command; the
   drive stops early when the scan shows an obstacle in its way (then the move is *blocked*), and
   when it has not finished within ``motion_timeout`` (blocked as well; a base that moved less than
   :data:`STUCK_FRACTION` of the way in that time is *stuck*: an error);
2. publishes a zero twist, waits ``settle`` seconds, and reads the sensors from the first messages
   that arrive after that: the scan's beams at the map's angles (:func:`beliefloc.ros.sensors.beam_ranges`)
   -- or, with :attr:`BridgeSettings.whole_scans` (``--filter lattice``), the whole scan and the
   laser's mount, which the lattice filter scores in full --,
   the classes on the detection topic (the ones the map's Look sensor knows; others are ignored);
3. answers with those raw readings, binned by the map's sensor models as the line protocol's are,
   and reports the odometry's motion ``start ⊖ end`` and the blocked flag
   (:class:`~beliefloc.robots.odometry.MotionReport`): the belief is predicted by what the base did.

**The scan's frame.** Ranges are turned into ranges from the base's centre using the laser's mount
(:attr:`BridgeSettings.laser_mount`, ``(x, y, yaw)`` on the base). Without one, the laser is taken to
sit at the base's centre, facing forward: the scan's ``frame_id`` must then be the odometry's
``child_frame_id`` (the base frame). With one, it must be :attr:`BridgeSettings.laser_frame`. A scan
in any other frame is an error (beams read in the wrong frame would be read at the wrong angles).

**The connection.** A dropped connection, a topic silent for ``timeout`` seconds, a stuck base or a
message that is not what its type says: :class:`~beliefloc.errors.ReplyError`. Whatever ends the
session, :meth:`RosbridgeRobot.stop` publishes a zero twist (after reconnecting, within ``timeout``,
when the connection dropped); :func:`stopped` does it for a ``with`` block.

The transport is a :class:`Link`: :class:`RoslibpyLink` (``roslibpy``, the ``[ros]`` extra) speaks
the rosbridge v2 JSON protocol to a standard ``rosbridge_server``.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from typing import Any, Protocol
from urllib.parse import urlsplit

import numpy as np

from beliefloc.continuous.motion import relative
from beliefloc.errors import ReplyError, UsageError
from beliefloc.model import GridLayout, Model
from beliefloc.pose import PoseEstimate, for_amcl
from beliefloc.robots.localize import Command
from beliefloc.robots.odometry import MotionReport, motion
from beliefloc.robots.readings import RawReading, ReadingBinner
from beliefloc.ros import messages
from beliefloc.ros.motion_control import Goal, MotionLimits, obstacle_ahead, velocity
from beliefloc.ros.sensors import (
    DETECTION_TYPES,
    ODOMETRY_TYPE,
    SCAN_TYPE,
    Odometry,
    Scan,
    base_points,
    beam_ranges,
    parse_detections,
    parse_odometry,
    parse_scan,
    whole_scan_reading,
)
from beliefloc.semantic_map.sections import HereSensor, LookSensor, ScanSensor

STUCK_FRACTION = 0.1
"""A base that covered less than this share of a commanded motion before ``motion_timeout`` is stuck."""
TWIST_TYPE = "geometry_msgs/Twist"
POSE_ARRAY_TYPE = "geometry_msgs/PoseArray"
INITIAL_POSE_TYPE = "geometry_msgs/PoseWithCovarianceStamped"
BELIEF_MASS = 0.99
"""The belief's PoseArray holds the likeliest states that together hold this much probability ..."""
BELIEF_POSES = 500
"""... and at most this many."""


@dataclass(frozen=True)
class BridgeSettings:
    """Topics, frames and the controller's settings of a live link (``localize --rosbridge``'s options)."""

    scan_topic: str = "/scan"
    odom_topic: str = "/odom"
    cmd_vel_topic: str = "/cmd_vel"
    detections_topic: str | None = None
    """Where Look detections come from; needed when the map has a Look sensor."""
    detections_type: str = DETECTION_TYPES[0]
    belief_topic: str = "/beliefloc/belief"
    initial_pose_topic: str = "/initialpose"
    map_frame: str = "map"
    laser_frame: str | None = None
    """The scan's expected ``frame_id``; None: the odometry's child frame (the laser at the base's centre)."""
    laser_mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
    robot_radius: float = 0.2
    """Metres: the base as a disc, for the obstacle stop."""
    margin: float = 0.1
    """Metres: a drive stops when an obstacle is nearer than ``robot_radius + margin`` ahead."""
    limits: MotionLimits = field(default_factory=MotionLimits)
    motion_timeout: float = 30.0
    """Seconds one motion may take."""
    settle: float = 0.5
    """Seconds between the stop and the readings."""
    timeout: float = 10.0
    """Seconds to wait for the connection and for a topic's next message."""
    whole_scans: bool = False
    """Answer a scan sensor with the whole LaserScan and the laser's mount
    (:func:`~beliefloc.ros.sensors.whole_scan_reading`), for the pose-lattice filter to score in
    full; False: the map's beams only."""


class Link(Protocol):
    """A connection to rosbridge: callbacks run on the link's own thread."""

    url: str

    def subscribe(self, topic: str, message_type: str, callback: Callable[[Any], None]) -> None: ...
    def advertise(self, topic: str, message_type: str) -> None: ...
    def publish(self, topic: str, body: Mapping[str, Any]) -> None: ...
    def on_connection(self, callback: Callable[[bool], None]) -> None:
        """``callback(False)`` when the connection drops, ``callback(True)`` when it is back."""

    @property
    def connected(self) -> bool: ...
    def close(self) -> None: ...


def check_map(binner: ReadingBinner, settings: BridgeSettings) -> GridLayout:
    """The map's grid, when the live link can drive its actions and read its sensors; else a
    :class:`UsageError` saying what it cannot do."""
    grid = binner.model.grid
    name = binner.smap.name
    if grid is None:
        raise UsageError(f"map {name!r}: --rosbridge drives a grid's moves, and this map has no grid")
    if grid.headings in (1, 8):
        why = (
            "its moves go up/down/left/right in the map's frame, and a differential base does not know its yaw in it"
            if grid.headings == 1
            else "a move along a diagonal heading is √2 cells long, and the base's heading on the map is not known"
        )
        raise UsageError(
            f"map {name!r} has {grid.headings} heading(s): --rosbridge drives maps with 2, 4 or 6 headings ({why})"
        )
    for sensor_name, sensor in binner.smap.sensors.items():
        if isinstance(sensor, HereSensor):
            raise UsageError(f"map {name!r}, sensor {sensor_name!r}: --rosbridge has no topic for a 'here' sensor")
        if isinstance(sensor, LookSensor):
            if sensor.angle_bins is not None:
                raise UsageError(
                    f"map {name!r}, sensor {sensor_name!r}: it bins viewing angles, which detections on a topic do "
                    "not give; remove its angle_bins to use it with --rosbridge"
                )
            if settings.detections_topic is None:
                raise UsageError(
                    f"map {name!r} has a Look sensor ({sensor_name!r}): give --detections-topic, the topic of the "
                    f"robot's detector ({' or '.join(DETECTION_TYPES)})"
                )
    return grid


def likely_states(belief: np.ndarray, mass: float = BELIEF_MASS, limit: int = BELIEF_POSES) -> np.ndarray:
    """The likeliest states, most likely first, that together hold ``mass`` (at most ``limit``)."""
    order = np.argsort(-belief, kind="stable")
    count = int(np.searchsorted(np.cumsum(belief[order]), mass * float(belief.sum()) - 1e-12)) + 1
    chosen: np.ndarray = order[: max(1, min(count, limit))]
    return chosen


@dataclass
class _Latest:
    """The newest message of a topic, and when it came (``time.monotonic()``)."""

    body: Any = None
    arrived: float = -math.inf
    count: int = 0


class RosbridgeRobot:
    """See the module. Subscribes and advertises on construction."""

    def __init__(self, binner: ReadingBinner, link: Link, settings: BridgeSettings) -> None:
        self.binner = binner
        self.link = link
        self.settings = settings
        self.grid = check_map(binner, settings)
        self._latest: dict[str, _Latest] = {}
        self._changed = threading.Condition()
        self._dropped = False
        self._report: MotionReport | None = None
        self._base_frame: str | None = None
        self._checked: tuple[int, bool, bool] = (-1, True, False)
        """``(scan count, forward, obstacle)`` of the last obstacle check."""
        self.last_stamp_ns = 0
        """The newest odometry stamp (the robot's clock): the stamp of what beliefloc publishes."""
        link.on_connection(self._connection)
        topics = [(settings.odom_topic, ODOMETRY_TYPE), (settings.scan_topic, SCAN_TYPE)]
        if settings.detections_topic is not None:
            topics.append((settings.detections_topic, settings.detections_type))
        for topic, message_type in topics:
            self._latest[topic] = _Latest()
            link.subscribe(topic, message_type, self._receiver(topic))
        link.advertise(settings.cmd_vel_topic, TWIST_TYPE)
        link.advertise(settings.belief_topic, POSE_ARRAY_TYPE)
        link.advertise(settings.initial_pose_topic, INITIAL_POSE_TYPE)

    # --- the link's thread ----------------------------------------------------------------------

    def _receiver(self, topic: str) -> Callable[[Any], None]:
        def receive(body: Any) -> None:
            with self._changed:
                latest = self._latest[topic]
                latest.body, latest.arrived, latest.count = body, time.monotonic(), latest.count + 1
                self._changed.notify_all()

        return receive

    def _connection(self, up: bool) -> None:
        with self._changed:
            if not up:
                self._dropped = True
            self._changed.notify_all()

    # --- waiting for messages -------------------------------------------------------------------

    def _check_link(self, during: str) -> None:
        if self._dropped:
            raise ReplyError(f"the connection to {self.link.url} dropped {during}")

    def _wait(self, topic: str, after: float, during: str, timeout: float | None = None) -> Any:
        """The first message of ``topic`` that arrived after ``after`` (monotonic seconds)."""
        limit = self.settings.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        with self._changed:
            while True:
                self._check_link(during)
                latest = self._latest[topic]
                if latest.arrived > after:
                    return latest.body
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    silent = "no message" if latest.count == 0 else "it stopped publishing: no new message"
                    hint = ": is the name right, and is the robot's driver running?" if latest.count == 0 else ""
                    raise ReplyError(
                        f"topic {topic} ({self._type(topic)}): {silent} within {limit:g} s {during}{hint} "
                        "(--ros-timeout sets the wait)"
                    )
                self._changed.wait(remaining)

    def _type(self, topic: str) -> str:
        s = self.settings
        return {s.scan_topic: SCAN_TYPE, s.odom_topic: ODOMETRY_TYPE}.get(topic, s.detections_type)

    def _odometry(self, after: float, during: str) -> Odometry:
        odometry = parse_odometry(self._wait(self.settings.odom_topic, after, during), self.settings.odom_topic)
        self.last_stamp_ns = max(self.last_stamp_ns, odometry.stamp_ns)
        if self._base_frame is None:
            self._base_frame = odometry.child_frame_id
        return odometry

    def _scan(self, after: float, during: str, timeout: float | None = None) -> Scan:
        topic = self.settings.scan_topic
        scan = parse_scan(self._wait(topic, after, during, timeout), topic)
        expected = self.settings.laser_frame or self._base_frame
        if expected is None:
            self._odometry(-math.inf, during)
            expected = self._base_frame
        if scan.frame_id != expected:
            if self.settings.laser_frame is None:
                raise ReplyError(
                    f"topic {topic}: the scan's frame is {scan.frame_id!r}, but without --laser-pose beliefloc reads "
                    f"the beams as seen from the base's centre, frame {expected!r} (the odometry's child frame): give "
                    f"--laser-frame {scan.frame_id} and --laser-pose X,Y,YAW (the laser's pose on the base, e.g. "
                    f"from 'ros2 run tf2_ros tf2_echo {expected} {scan.frame_id}')"
                )
            raise ReplyError(
                f"topic {topic}: the scan's frame is {scan.frame_id!r}, but --laser-frame says {expected!r} (the frame "
                "of --laser-pose): beams read in another frame would be read at the wrong angles"
            )
        return scan

    # --- the robot interface --------------------------------------------------------------------

    def motion_report(self) -> MotionReport | None:
        return self._report

    def act(self, command: Command) -> Mapping[str, RawReading]:
        """Drive the action's motion, settle, read its sensors (see the module)."""
        action = command.action
        during = f"during action {command.seq} ({action.name})"
        self._report = None
        wanted = motion(self.grid, action)
        if wanted is not None:
            self._report = self._move(wanted, during)
        settled = time.monotonic()
        readings: dict[str, RawReading] = {}
        described = self.binner.describe(action)  # the beams in radians, counter-clockwise (REP 103)
        for slot, description in zip(self.binner.sensors(action), described, strict=True):
            sensor = slot.sensor
            if isinstance(sensor, ScanSensor):
                scan = self._scan(settled, during)
                beams = [float(b) for b in description["beams"]]
                scan_topic, mount = self.settings.scan_topic, self.settings.laser_mount
                ranges = beam_ranges(scan, beams, mount, scan_topic)  # the map's beams must be in the sweep anyway
                whole = self.settings.whole_scans
                readings[slot.name] = whole_scan_reading(scan, mount, scan_topic) if whole else ranges
            elif isinstance(sensor, LookSensor):
                topic = self.settings.detections_topic
                assert topic is not None  # check_map
                seen = parse_detections(self._wait(topic, settled, during), topic, self.settings.detections_type)
                readings[slot.name] = [name for name in seen if name in slot.classes]
        return readings

    def _pause(self, seconds: float, during: str) -> None:
        deadline = time.monotonic() + seconds
        with self._changed:
            while (remaining := deadline - time.monotonic()) > 0:
                self._check_link(during)
                self._changed.wait(remaining)
        self._check_link(during)

    def _move(self, wanted: Mapping[str, float], during: str) -> MotionReport:
        """Drive ``wanted``, stop, settle; what the base did. A drive stopped short (an obstacle, the
        timeout) drives back to where it started, so that a blocked move leaves the robot where the
        map's ``T_a`` says a blocked move does: then only the blocked flag is reported."""
        s = self.settings
        goal = Goal("turn", float(wanted["turn"])) if "turn" in wanted else Goal("drive", float(wanted["advance"]))
        start = self._odometry(-math.inf, during)
        returned = False
        try:
            progress, stopped_short = self._follow(goal, start, during, "")
            if stopped_short and goal.kind == "drive" and abs(progress[0]) > s.limits.tolerance:
                back = Goal("drive", -progress[0])
                now = self._odometry(-math.inf, during)
                _, again = self._follow(back, now, during, " back to where it started")
                returned = not again
        finally:
            self._publish_stop()
        self._pause(s.settle, during)
        end = self._odometry(time.monotonic(), during)
        if not stopped_short:
            return MotionReport(None, False)  # the motion the action asks for, within the controller's tolerance
        if returned or (goal.kind == "drive" and abs(progress[0]) <= s.limits.tolerance):
            return MotionReport(None, True)
        dx, dy, dyaw = (float(v) for v in relative(np.array(start.pose), np.array(end.pose)))
        return MotionReport((dx, dy, dyaw), stopped_short)

    def _follow(self, goal: Goal, start: Odometry, during: str, why: str) -> tuple[tuple[float, float, float], bool]:
        """Publish the controller's twist at each odometry message until ``goal`` is reached from
        ``start``; ``(progress, stopped short)``. A stuck base is a :class:`ReplyError`."""
        s = self.settings
        unit = "rad" if goal.kind == "turn" else "m"
        what = f"{goal.kind} of {goal.amount:.3g} {unit}{why}"
        started = time.monotonic()
        origin = np.array(start.pose)
        previous, turned = start, 0.0
        progress = (0.0, 0.0, 0.0)
        while True:
            odometry = self._odometry(self._latest[s.odom_topic].arrived, f"{during}, in the {what}")
            turned += math.remainder(odometry.yaw - previous.yaw, 2 * math.pi)
            previous = odometry
            dx, dy, _ = (float(v) for v in relative(origin, np.array(odometry.pose)))
            progress = (dx, dy, turned)
            command = velocity(goal, progress, s.limits)
            if command is None:
                return progress, False
            if goal.kind == "drive" and self._obstacle(goal.amount > 0, during):
                return progress, True
            if time.monotonic() - started > s.motion_timeout:
                if goal.done_fraction(progress) < STUCK_FRACTION:
                    raise ReplyError(
                        f"the robot did not move {during}: its odometry on {s.odom_topic} covered "
                        f"{max(goal.done_fraction(progress), 0.0) + 0.0:.0%} of the {what} in {s.motion_timeout:g} s "
                        f"(--motion-timeout): is the base stuck, its motors off, or {s.cmd_vel_topic} not the "
                        "topic it obeys?"
                    )
                return progress, True
            self.link.publish(s.cmd_vel_topic, messages.twist(*command))

    def _obstacle(self, forward: bool, during: str) -> bool:
        """Whether the newest scan shows an obstacle in the drive's way (checked once per scan)."""
        s = self.settings
        latest = self._latest[s.scan_topic]
        if latest.count != self._checked[0] or forward != self._checked[1]:
            scan = self._scan(-math.inf, during)  # the newest one (waits for the first)
            ahead = obstacle_ahead(base_points(scan, s.laser_mount), forward, s.robot_radius, s.margin)
            self._checked = (latest.count, forward, ahead is not None)
        return self._checked[2]

    # --- what beliefloc publishes ---------------------------------------------------------------

    def _publish_stop(self) -> None:
        self.link.publish(self.settings.cmd_vel_topic, messages.twist())

    def publish_belief(self, model: Model, belief: np.ndarray) -> None:
        """The likeliest states (:func:`likely_states`) as a PoseArray on the belief topic."""
        from beliefloc.pose import state_pose

        assert model.grid is not None
        poses = [state_pose(model.grid, int(state)) for state in likely_states(belief)]
        body = messages.pose_array(poses, self.settings.map_frame, self.last_stamp_ns)
        self.link.publish(self.settings.belief_topic, body)

    def publish_initial_pose(self, estimate: PoseEstimate) -> None:
        """The pose localized (:meth:`beliefloc.robots.localize.Localization.pose_estimate`) as AMCL's
        initial pose on ``/initialpose``, its covariance with no negative entry as every AMCL accepts it
        (:func:`beliefloc.pose.for_amcl`: Rolling's refuses one)."""
        estimate = for_amcl(estimate)
        body = messages.pose_with_covariance_stamped(estimate, self.settings.map_frame, self.last_stamp_ns)
        self.link.publish(self.settings.initial_pose_topic, body)

    def stop(self) -> bool:
        """Publish a zero twist; after a drop, wait (``timeout``) for the link to come back first.
        Whether the stop went out on a live connection."""
        deadline = time.monotonic() + self.settings.timeout
        while not self.link.connected and time.monotonic() < deadline:
            time.sleep(0.05)
        if not self.link.connected:
            return False
        for _ in range(3):  # a lost message must not leave the base driving
            self._publish_stop()
            time.sleep(0.02)
        return True


@contextmanager
def stopped(robot: RosbridgeRobot) -> Iterator[RosbridgeRobot]:
    """``with stopped(robot):`` the robot is told to stop however the block ends; when the stop
    cannot be sent, a :class:`ReplyError` from the block says so, and a block that ended well
    raises one."""
    try:
        yield robot
    except ReplyError as exc:
        if not robot.stop():
            raise ReplyError(f"{exc}; {_NOT_STOPPED.format(url=robot.link.url)}") from None
        topic = robot.settings.cmd_vel_topic
        raise ReplyError(f"{exc}; the robot was told to stop (a zero twist on {topic})") from None
    except BaseException:
        robot.stop()
        raise
    else:
        if not robot.stop():
            raise ReplyError(_NOT_STOPPED.format(url=robot.link.url).capitalize())


_NOT_STOPPED = (
    "the robot could not be told to stop: the connection to {url} did not come back; stop it by hand, and give its "
    "base a cmd_vel timeout"
)


class RoslibpyLink:
    """A :class:`Link` over ``roslibpy`` (Twisted in a background thread; it reconnects by itself)."""

    def __init__(self, url: str, timeout: float) -> None:
        try:
            import roslibpy
        except ImportError:
            raise UsageError(
                "--rosbridge needs roslibpy: pip install 'beliefloc[ros]' (or pip install roslibpy)"
            ) from None
        parts = urlsplit(url)
        try:
            port = parts.port
        except ValueError:
            port = None
        if parts.scheme not in ("ws", "wss") or not parts.hostname or (parts.path not in ("", "/")):
            raise UsageError(f"--rosbridge {url!r}: give rosbridge's websocket as ws://HOST:PORT, e.g. ws://robot:9090")
        self.url = url
        self._roslibpy = roslibpy
        self._ros = roslibpy.Ros(host=parts.hostname, port=port or 9090, is_secure=parts.scheme == "wss")
        self._topics: dict[str, Any] = {}
        self._callbacks: list[Callable[[bool], None]] = []
        self._closing = False
        self._ros.on("close", lambda *_: self._tell(False))
        self._ros.on("ready", lambda *_: self._tell(True))
        try:
            self._ros.run(timeout=timeout)
        except Exception as exc:  # roslibpy raises a plain Exception on a timeout
            self.close()
            raise ReplyError(f"could not connect to rosbridge at {url} within {timeout:g} s ({exc})") from None

    def _tell(self, up: bool) -> None:
        if self._closing:
            return
        for callback in list(self._callbacks):
            callback(up)

    def on_connection(self, callback: Callable[[bool], None]) -> None:
        self._callbacks.append(callback)

    @property
    def connected(self) -> bool:
        return bool(self._ros.is_connected)

    def _topic(self, topic: str, message_type: str) -> Any:
        if topic not in self._topics:
            self._topics[topic] = self._roslibpy.Topic(self._ros, topic, message_type, queue_length=1)
        return self._topics[topic]

    def subscribe(self, topic: str, message_type: str, callback: Callable[[Any], None]) -> None:
        self._topic(topic, message_type).subscribe(callback)

    def advertise(self, topic: str, message_type: str) -> None:
        self._topic(topic, message_type).advertise()

    def publish(self, topic: str, body: Mapping[str, Any]) -> None:
        self._topics[topic].publish(self._roslibpy.Message(dict(body)))

    def close(self) -> None:
        """Close the connection and stop reconnecting (roslibpy's factory retries a connection that
        never came up, or that dropped, until it is told not to)."""
        self._closing = True
        with suppress(Exception):  # closing a link that is already gone
            from twisted.internet import reactor

            reactor.callFromThread(self._ros.factory.stopTrying)
            self._ros.close()
