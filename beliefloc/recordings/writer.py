"""Writing a simulated run as a ROS recording, for test data: what a TurtleBot4 records.

:func:`write_run` turns a :class:`~beliefloc.continuous.world.Run` into a rosbag2 (sqlite3 or MCAP
storage) or a ROS 1 ``.bag``, with the topics ``ros2 bag record`` of a TurtleBot4 holds:

- ``/scan`` ``sensor_msgs/msg/LaserScan`` in frame ``rplidar_link`` (REP 117 readings as float32);
- ``/odom`` ``nav_msgs/msg/Odometry`` (``odom`` -> ``base_link``) and the same transform on ``/tf``
  (both optional, so that a bag can carry only one of them);
- ``/tf_static``: ``base_link -> shell_link -> rplidar_link`` (the laser's mount through an
  intermediate frame) and a number of other static frames (wheels, bumper, cameras);
- ``/cmd_vel`` ``geometry_msgs/msg/Twist`` and ``/robot_description`` ``std_msgs/msg/String``: topics
  beliefloc does not read.

Message times (the bag's receive times) trail the header stamps by a few milliseconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from beliefloc.continuous.world import Run
from beliefloc.pose import Pose
from beliefloc.ros import messages as ros

STORAGES = ("sqlite3", "mcap", "ros1")
"""The kinds of recording :func:`write_run` writes."""


@dataclass(frozen=True)
class FrameSpec:
    """How the run's frames are named and how the laser is mounted through an intermediate frame."""

    base: str = "base_link"
    odom: str = "odom"
    laser: str = "rplidar_link"
    intermediate: str = "shell_link"
    base_to_intermediate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """``(x, y, yaw)`` of the intermediate frame in ``base``."""
    intermediate_to_laser: tuple[float, float, float] = (-0.04, 0.0, math.pi / 2)
    """``(x, y, yaw)`` of the laser in the intermediate frame (+90° about z, as a TurtleBot4's RPLIDAR)."""
    extra_static: int = 12
    """Other static frames hung off ``base`` (``wheel_0``... stand-ins for a real robot's hundred)."""

    @property
    def mount(self) -> tuple[float, float, float]:
        """The laser's pose in ``base``: the two static transforms composed."""
        ax, ay, ayaw = self.base_to_intermediate
        bx, by, byaw = self.intermediate_to_laser
        c, s = math.cos(ayaw), math.sin(ayaw)
        return (ax + c * bx - s * by, ay + s * bx + c * by, ayaw + byaw)


def _transform(typestore: Any, ns: int, parent: str, child: str, pose: Sequence[float]) -> Any:
    x, y, yaw = (float(v) for v in pose)
    body = ros.transform_stamped(parent, child, Pose(x, y, yaw), ns)
    return ros.to_typed(typestore, "geometry_msgs/msg/TransformStamped", body)


def write_run(
    run: Run,
    path: Path,
    storage: str,
    *,
    frames: FrameSpec | None = None,
    odometry_topic: bool = True,
    tf_odometry: bool = True,
    scan_topic: str = "/scan",
    scan_angle_sign: int = 1,
    scan_frame: str | None = None,
) -> None:
    """Write ``run`` to ``path`` (a folder for rosbag2, a ``.bag`` file for ROS 1; must not exist).

    ``storage``: one of :data:`STORAGES`. ``scan_frame`` names the scans' frame instead of the
    laser's (a frame /tf_static does not connect, for the bad-input tests). ``scan_angle_sign = -1``
    writes each scan reversed with a negative ``angle_increment`` (a clockwise sweep, the same
    beams). The run's laser mount must be ``frames.mount``."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    if storage not in STORAGES:
        raise ValueError(f"storage must be one of {', '.join(STORAGES)}, got {storage!r}")
    frames = frames or FrameSpec()
    if not np.allclose(frames.mount, run.laser.mount, atol=1e-9):
        raise ValueError(f"the run's laser mount {run.laser.mount} is not the frames' {frames.mount}")
    ros1 = storage == "ros1"
    typestore = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if "tf2_msgs/msg/TFMessage" not in typestore.types:  # rosbags' noetic store lacks tf2_msgs
        from rosbags.typesys import get_types_from_msg

        typestore.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    types = typestore.types
    serialize: Callable[[Any, str], Any] = typestore.serialize_ros1 if ros1 else typestore.serialize_cdr
    messages: list[tuple[int, str, str, Any]] = []  # (receive time, topic, msgtype, message)

    laser = run.laser
    start = int(min(run.scan_stamps[0], run.odom_stamps[0]))
    statics = [
        _transform(typestore, start, frames.base, frames.intermediate, frames.base_to_intermediate),
        _transform(typestore, start, frames.intermediate, frames.laser, frames.intermediate_to_laser),
    ]
    for n in range(frames.extra_static):
        angle = 2 * math.pi * n / max(1, frames.extra_static)
        statics.append(
            _transform(
                typestore,
                start,
                frames.base,
                f"static_part_{n}",
                (0.1 * math.cos(angle), 0.1 * math.sin(angle), 0),
            )
        )
    messages.append(
        (start, "/tf_static", "tf2_msgs/msg/TFMessage", types["tf2_msgs/msg/TFMessage"](transforms=statics))
    )
    messages.append((start, "/robot_description", "std_msgs/msg/String", types["std_msgs/msg/String"](data="<robot/>")))

    angle_min, increment = laser.angle_min, laser.angle_increment
    if scan_angle_sign < 0:
        angle_min, increment = laser.angle_max, -laser.angle_increment
    for stamp, ranges in zip(run.scan_stamps.tolist(), run.ranges, strict=True):
        values = ranges[::-1] if scan_angle_sign < 0 else ranges
        body = ros.laser_scan(
            scan_frame or frames.laser,
            stamp,
            angle_min=angle_min,
            angle_increment=increment,
            ranges=np.asarray(values, dtype=np.float32),
            range_min=laser.range_min,
            range_max=laser.range_max,
            time_increment=laser.time_increment,
            scan_time=laser.scan_time,
            intensities=np.zeros(0, dtype=np.float32),
        )
        msg = ros.to_typed(typestore, "sensor_msgs/msg/LaserScan", body)
        messages.append((stamp + 3_000_000, scan_topic, "sensor_msgs/msg/LaserScan", msg))

    poses = run.odom_poses
    stamps = run.odom_stamps
    dt = np.diff(stamps) / 1e9
    for n, stamp in enumerate(stamps.tolist()):
        x, y, yaw = (float(v) for v in poses[n])
        m = min(n, len(dt) - 1)
        forward = float(np.hypot(*(poses[m + 1, :2] - poses[m, :2])) / dt[m]) if len(dt) else 0.0
        turn = float(math.remainder(poses[m + 1, 2] - poses[m, 2], 2 * math.pi) / dt[m]) if len(dt) else 0.0
        received = stamp + 1_000_000
        if odometry_topic:
            body = ros.odometry(
                Pose(x, y, yaw), stamp, forward=forward, turn=turn, frame_id=frames.odom, child_frame_id=frames.base
            )
            odom = ros.to_typed(typestore, "nav_msgs/msg/Odometry", body)
            messages.append((received, "/odom", "nav_msgs/msg/Odometry", odom))
        if tf_odometry:
            tf = types["tf2_msgs/msg/TFMessage"](
                transforms=[_transform(typestore, stamp, frames.odom, frames.base, (x, y, yaw))]
            )
            messages.append((received + 200_000, "/tf", "tf2_msgs/msg/TFMessage", tf))
        if n % 2 == 0:
            cmd = ros.to_typed(typestore, "geometry_msgs/msg/Twist", ros.twist(forward, turn))
            messages.append((received - 20_000_000, "/cmd_vel", "geometry_msgs/msg/Twist", cmd))

    messages.sort(key=lambda item: item[0])
    if ros1:
        with Writer1(path) as writer:
            conns: dict[str, Any] = {}
            for t, topic, msgtype, msg in messages:
                if topic not in conns:
                    latching = 1 if topic in ("/tf_static", "/robot_description") else None
                    conns[topic] = writer.add_connection(topic, msgtype, typestore=typestore, latching=latching)
                writer.write(conns[topic], t, serialize(msg, msgtype))
        return
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=8, storage_plugin=plugin) as writer2:
        conns = {}
        for t, topic, msgtype, msg in messages:
            if topic not in conns:
                conns[topic] = writer2.add_connection(topic, msgtype, typestore=typestore)
            writer2.write(conns[topic], t, serialize(msg, msgtype))
