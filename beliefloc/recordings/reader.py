"""Reading what a robot recorded: laser scans, odometry and the laser's mount from a ROS bag.

With the ``rosbags`` library (pure Python, no ROS installation): rosbag2 folders in sqlite3 or MCAP
storage (any metadata version rosbags reads, 1 to 9) and ROS 1 ``.bag`` files.

**Topics.** The scans are the one ``sensor_msgs/msg/LaserScan`` topic of the bag (``scan_topic`` to
choose among several). The odometry is the one ``nav_msgs/msg/Odometry`` topic (``odom_topic`` to
choose), else the ``odom -> base`` transforms on ``/tf``: the dynamic transform whose child is the
scan's frame or one of its ancestors in ``/tf_static``. The base frame is the odometry's
``child_frame_id`` (or that transform's child).

**The laser's mount** (its pose in the base frame) is the chain of ``/tf_static`` transforms from the
base frame to the scan's ``frame_id``, through any intermediate frames, projected on the plane
(x, y and the rotation about z); ``laser_pose`` overrides it.

**Time.** Scans and odometry are not synchronised: the odometry pose at a scan's header stamp is
interpolated between the two odometry messages around it (yaw unwrapped). A scan more than
:data:`MAX_EXTRAPOLATION_NS` outside the odometry's time span is dropped (with a warning). Beam
``i`` was measured at ``stamp + i * time_increment`` (REP 117's LaserScan; ``scan_time / n`` when
``time_increment`` is 0): :meth:`Recording.yaw_offsets` gives the base's turn since the stamp
at each beam, so that a sweep taken while turning can be de-skewed.

**Readings** follow REP 117: ``+inf`` no return, ``-inf`` too close, NaN invalid; ``angle_increment``
may be negative (a clockwise sweep). Guards: a zero or non-finite ``angle_increment``, a scan with no
or more than :data:`MAX_BEAMS` readings, odometry that moves faster than :data:`MAX_SPEED` between two
messages (a jump), a bag larger than :data:`MAX_BAG_BYTES`: :class:`RecordingError`, one paragraph
naming the bag, the topic and what is wrong.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from beliefloc.continuous.motion import compose
from beliefloc.errors import RecordingError

LASER_SCAN = "sensor_msgs/msg/LaserScan"
ODOMETRY = "nav_msgs/msg/Odometry"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
MAX_EXTRAPOLATION_NS = 200_000_000
"""A scan this far (0.2 s) outside the odometry's time span is dropped: its pose is unknown."""
MAX_SPEED = 10.0
"""Metres per second: odometry moving faster than this between two messages has jumped."""
MAX_BEAMS = 100_000
"""The most readings in one scan."""
MAX_BAG_BYTES = 20 * 2**30
"""The largest recording read (20 GiB)."""


@dataclass(frozen=True)
class ScanMessage:
    """One ``sensor_msgs/LaserScan``, as read."""

    stamp: int
    """Header stamp, integer nanoseconds."""
    angle_min: float
    angle_increment: float
    time_increment: float
    scan_time: float
    range_min: float
    range_max: float
    ranges: np.ndarray
    """float64, REP 117 values kept."""


@dataclass(frozen=True)
class Recording:
    """The scans and odometry of one bag, and how the laser is mounted."""

    path: Path
    scan_topic: str
    odometry_source: str
    """``"/odom (nav_msgs/msg/Odometry)"`` or ``"/tf odom -> base_link"``."""
    base_frame: str
    laser_frame: str
    mount: tuple[float, float, float]
    """The laser's ``(x, y, yaw)`` in the base frame."""
    scans: tuple[ScanMessage, ...]
    odom_stamps: np.ndarray
    """Integer nanoseconds, increasing, shape ``(K,)``."""
    odom_poses: np.ndarray
    """``(K, 3)`` base poses ``(x, y, yaw)`` in the odometry frame."""
    warnings: tuple[str, ...] = field(default=())

    @property
    def start(self) -> int:
        return int(min(self.scans[0].stamp, self.odom_stamps[0]))

    @property
    def end(self) -> int:
        return int(max(self.scans[-1].stamp, self.odom_stamps[-1]))

    def odometry_at(self, stamps: np.ndarray) -> np.ndarray:
        """The odometry pose at each stamp (ns), interpolated; ``(N, 3)``."""
        t = np.asarray(stamps, dtype=np.float64) - float(self.odom_stamps[0])
        ts = (self.odom_stamps - self.odom_stamps[0]).astype(np.float64)
        yaw = np.unwrap(self.odom_poses[:, 2])
        out = np.stack(
            [np.interp(t, ts, self.odom_poses[:, 0]), np.interp(t, ts, self.odom_poses[:, 1]), np.interp(t, ts, yaw)],
            axis=-1,
        )
        out[..., 2] = np.mod(out[..., 2] + math.pi, 2 * math.pi) - math.pi
        return out

    def _unwrapped_yaw(self, stamps: np.ndarray) -> np.ndarray:
        ts = (self.odom_stamps - self.odom_stamps[0]).astype(np.float64)
        t = np.asarray(stamps, dtype=np.float64) - float(self.odom_stamps[0])
        return np.interp(t, ts, np.unwrap(self.odom_poses[:, 2]))

    def beam_times(self, scan: ScanMessage) -> np.ndarray:
        """Nanoseconds since the stamp at which each beam was measured."""
        n = scan.ranges.size
        step = scan.time_increment
        if not (math.isfinite(step) and step > 0):
            step = scan.scan_time / n if math.isfinite(scan.scan_time) and scan.scan_time > 0 else 0.0
        return np.arange(n) * step * 1e9

    def yaw_offsets(self, scan: ScanMessage) -> np.ndarray:
        """The base's yaw at each beam's time less its yaw at the scan's stamp (radians, ``(n,)``)."""
        times = scan.stamp + self.beam_times(scan)
        offsets: np.ndarray = self._unwrapped_yaw(times) - self._unwrapped_yaw(np.array([scan.stamp]))[0]
        return offsets

    def yaw_rate(self, stamp: int, span_ns: int = 100_000_000) -> float:
        """Rad/s the base turns over ``[stamp - span/2, stamp + span/2]`` by the odometry."""
        yaws = self._unwrapped_yaw(np.array([stamp - span_ns // 2, stamp + span_ns // 2]))
        return float(yaws[1] - yaws[0]) / (span_ns / 1e9)


# --- reading ---------------------------------------------------------------------------------------


def _fail(path: Path, message: str) -> RecordingError:
    return RecordingError(f"{path}: {message}")


def _bag_paths(path: Path) -> Path:
    """The path rosbags opens: a rosbag2 folder (with metadata.yaml) or a ROS 1 ``.bag`` file."""
    if not path.exists():
        raise _fail(path, "no such file or folder; give a rosbag2 folder (with metadata.yaml) or a ROS 1 .bag file")
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            raise _fail(
                path,
                "this folder has no metadata.yaml, so it is not a rosbag2 recording ('ros2 bag record' writes one "
                "beside the .db3 or .mcap files; 'ros2 bag reindex' rebuilds it)",
            )
        size = sum(f.stat().st_size for f in path.iterdir() if f.is_file())
    elif path.is_file():
        suffix = path.suffix.lower()
        if suffix in (".db3", ".mcap") and (path.parent / "metadata.yaml").is_file():
            return _bag_paths(path.parent)
        if suffix != ".bag":
            raise _fail(
                path,
                "is not a recording beliefloc reads: give a rosbag2 folder (with metadata.yaml; sqlite3 or MCAP "
                "storage) or a ROS 1 .bag file",
            )
        size = path.stat().st_size
    else:
        raise _fail(path, "is neither a regular file nor a folder")
    if size > MAX_BAG_BYTES:
        raise _fail(path, f"{size:,} bytes is more than the {MAX_BAG_BYTES:,} bytes a recording may have")
    return path


@contextmanager
def _reading(path: Path, what: str) -> Iterator[None]:
    """Turn whatever rosbags (or sqlite, mcap, lz4...) raises on a broken file into a RecordingError."""
    try:
        yield
    except RecordingError:
        raise
    except Exception as exc:  # a broken file may make the reader raise anything
        text = str(exc) or type(exc).__name__
        raise _fail(path, f"cannot be read as a ROS recording ({what}): {text}") from None


def _stamp_ns(header: Any) -> int:
    stamp = header.stamp
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def read_recording(
    path: str | Path,
    *,
    scan_topic: str | None = None,
    odom_topic: str | None = None,
    laser_pose: tuple[float, float, float] | None = None,
) -> Recording:
    """Read a recording's scans, odometry and laser mount (see the module's docstring)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    bag = Path(path)
    opened = _bag_paths(bag)
    warnings: list[str] = []
    with _reading(bag, "opening it"):
        reader = AnyReader([opened], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    try:
        topics: dict[str, str] = {}
        for conn in reader.connections:
            topics.setdefault(conn.topic, conn.msgtype)
        listing = ", ".join(f"{t} ({m})" for t, m in sorted(topics.items())) or "none"
        scan_name = _choose(bag, topics, scan_topic, (LASER_SCAN,), "--scan-topic", "LaserScan", listing)
        odom_types = (ODOMETRY, TF_MESSAGE)
        if odom_topic is None:
            odoms = [t for t, m in topics.items() if m == ODOMETRY]
            if len(odoms) > 1:
                raise _fail(
                    bag,
                    f"has {len(odoms)} nav_msgs/msg/Odometry topics ({', '.join(sorted(odoms))}); choose one with "
                    "--odom-topic",
                )
            if odoms:
                odom_name = odoms[0]
            elif "/tf" in topics and topics["/tf"] == TF_MESSAGE:
                odom_name = "/tf"
            else:
                raise _fail(
                    bag,
                    f"has no odometry: no nav_msgs/msg/Odometry topic and no /tf transforms (topics: {listing})",
                )
        else:
            odom_name = _choose(bag, topics, odom_topic, odom_types, "--odom-topic", "Odometry or TFMessage", listing)

        wanted = {scan_name, odom_name, "/tf_static"}
        scans: list[ScanMessage] = []
        static_edges: dict[str, tuple[str, tuple[float, float, float]]] = {}
        dynamic: dict[tuple[str, str], list[tuple[int, float, float, float]]] = {}
        odom_rows: list[tuple[int, float, float, float]] = []
        odom_child: str | None = None
        laser_frame: str | None = None
        connections = [c for c in reader.connections if c.topic in wanted]
        with _reading(bag, "reading its messages"):
            for conn, _, raw in reader.messages(connections=connections):
                topic = conn.topic
                msg: Any = reader.deserialize(raw, conn.msgtype)
                if topic == scan_name:
                    scan = _scan(bag, topic, msg, len(scans))
                    laser_frame = laser_frame or str(msg.header.frame_id)
                    scans.append(scan)
                elif conn.msgtype == ODOMETRY and topic == odom_name:
                    pose = msg.pose.pose
                    odom_rows.append((_stamp_ns(msg.header), pose.position.x, pose.position.y, _yaw(pose.orientation)))
                    odom_child = odom_child or str(msg.child_frame_id)
                elif conn.msgtype == TF_MESSAGE:
                    for tf in msg.transforms:
                        parent, child = str(tf.header.frame_id).lstrip("/"), str(tf.child_frame_id).lstrip("/")
                        tr = tf.transform
                        value = (float(tr.translation.x), float(tr.translation.y), _yaw(tr.rotation))
                        if topic == "/tf_static":
                            static_edges[child] = (parent, value)
                        elif topic == odom_name:
                            dynamic.setdefault((parent, child), []).append((_stamp_ns(tf.header), *value))
    finally:
        reader.close()

    if not scans:
        raise _fail(bag, f"topic {scan_name} (sensor_msgs/msg/LaserScan) holds no messages")
    laser_frame = (laser_frame or "").lstrip("/")
    ancestors = _ancestors(laser_frame, static_edges)
    if odom_name == "/tf" or topics.get(odom_name) == TF_MESSAGE:
        candidates = [(p, c) for (p, c) in dynamic if c in ancestors]
        if not candidates:
            seen = ", ".join(f"{p} -> {c}" for p, c in sorted(dynamic)) or "none"
            raise _fail(
                bag,
                f"topic {odom_name}: no transform moves the scan's frame {laser_frame!r} or a frame above it in "
                f"/tf_static (its chain: {' <- '.join(ancestors)}); dynamic transforms seen: {seen}",
            )
        parent, base = min(candidates, key=lambda pc: ancestors.index(pc[1]))
        odom_rows = dynamic[(parent, base)]
        source = f"{odom_name} {parent} -> {base}"
    else:
        base = (odom_child or "base_link").lstrip("/")
        source = f"{odom_name} ({ODOMETRY})"
    if not odom_rows:
        raise _fail(bag, f"topic {odom_name} holds no odometry of {base!r}")
    if laser_pose is not None:
        mount = tuple(float(v) for v in laser_pose)
    else:
        if base not in ancestors:
            chain = " <- ".join(ancestors)
            raise _fail(
                bag,
                f"topic {scan_name}: the scan's frame {laser_frame!r} has no path to the base frame {base!r} in "
                f"/tf_static (its chain: {chain}); give the laser's mount with --laser-pose X,Y,YAW",
            )
        mount = _chain(laser_frame, base, static_edges)
    stamps, poses = _odometry_series(bag, odom_name, odom_rows)
    kept = [s for s in scans if stamps[0] - MAX_EXTRAPOLATION_NS <= s.stamp <= stamps[-1] + MAX_EXTRAPOLATION_NS]
    if len(kept) < len(scans):
        warnings.append(
            f"{bag}: {len(scans) - len(kept)} of {len(scans)} scans on {scan_name} lie outside the odometry's time "
            "span and were dropped"
        )
    if not kept:
        raise _fail(bag, f"topic {scan_name}: no scan lies within the time span of the odometry on {odom_name}")
    kept.sort(key=lambda s: s.stamp)
    return Recording(
        path=bag,
        scan_topic=scan_name,
        odometry_source=source,
        base_frame=base,
        laser_frame=laser_frame,
        mount=(mount[0], mount[1], mount[2]),
        scans=tuple(kept),
        odom_stamps=stamps,
        odom_poses=poses,
        warnings=tuple(warnings),
    )


def _choose(
    bag: Path,
    topics: dict[str, str],
    chosen: str | None,
    types: tuple[str, ...],
    option: str,
    kind: str,
    listing: str,
) -> str:
    if chosen is not None:
        if chosen not in topics:
            raise _fail(bag, f"has no topic {chosen} ({option}); its topics: {listing}")
        if topics[chosen] not in types:
            raise _fail(
                bag,
                f"topic {chosen} carries {topics[chosen]}, a message type beliefloc does not read for {option} "
                f"(it reads {' or '.join(types)})",
            )
        return chosen
    found = sorted(t for t, m in topics.items() if m in types)
    if not found:
        raise _fail(bag, f"has no {kind} topic ({' or '.join(types)}); its topics: {listing}")
    if len(found) > 1:
        raise _fail(bag, f"has {len(found)} {kind} topics ({', '.join(found)}); choose one with {option}")
    return found[0]


def _scan(bag: Path, topic: str, msg: Any, index: int) -> ScanMessage:
    ranges = np.asarray(msg.ranges, dtype=np.float64)
    stamp = _stamp_ns(msg.header)
    where = f"topic {topic}, scan {index} (stamp {stamp} ns)"
    increment = float(msg.angle_increment)
    if not math.isfinite(increment) or increment == 0.0:
        raise _fail(bag, f"{where}: angle_increment is {increment:g}; beams need distinct angles")
    for name in ("angle_min", "range_min", "range_max"):
        if not math.isfinite(float(getattr(msg, name))):
            raise _fail(bag, f"{where}: {name} is {float(getattr(msg, name))}, not a number")
    if not 0 <= float(msg.range_min) < float(msg.range_max):
        raise _fail(bag, f"{where}: range_min {msg.range_min:g} and range_max {msg.range_max:g} are not 0 <= min < max")
    if ranges.size == 0 or ranges.size > MAX_BEAMS:
        raise _fail(bag, f"{where}: {ranges.size} readings (a scan has 1 to {MAX_BEAMS:,})")
    return ScanMessage(
        stamp=stamp,
        angle_min=float(msg.angle_min),
        angle_increment=increment,
        time_increment=float(msg.time_increment),
        scan_time=float(msg.scan_time),
        range_min=float(msg.range_min),
        range_max=float(msg.range_max),
        ranges=ranges,
    )


def _ancestors(frame: str, edges: dict[str, tuple[str, tuple[float, float, float]]]) -> list[str]:
    """``frame`` and its parents up the static tree, nearest first (a loop stops the walk)."""
    chain = [frame]
    while chain[-1] in edges and len(chain) <= len(edges):
        parent = edges[chain[-1]][0].lstrip("/")
        if parent in chain:
            break
        chain.append(parent)
    return chain


def _chain(frame: str, base: str, edges: dict[str, tuple[str, tuple[float, float, float]]]) -> tuple[float, ...]:
    """The pose of ``frame`` in ``base``: the static transforms from ``base`` down to ``frame`` composed."""
    path = _ancestors(frame, edges)
    pose = np.zeros((1, 3))
    for child in reversed(path[: path.index(base)]):
        pose = compose(pose, np.array(edges[child][1]))
    return tuple(float(v) for v in pose[0])


def _odometry_series(
    bag: Path, topic: str, rows: list[tuple[int, float, float, float]]
) -> tuple[np.ndarray, np.ndarray]:
    data = sorted(rows, key=lambda r: r[0])
    stamps = np.array([r[0] for r in data], dtype=np.int64)
    poses = np.array([r[1:] for r in data], dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(poses)):
        bad = int(np.flatnonzero(~np.isfinite(poses).all(axis=1))[0])
        raise _fail(bag, f"topic {topic}: the odometry at stamp {stamps[bad]} ns is not finite")
    keep = np.concatenate([[True], np.diff(stamps) > 0])  # one pose per stamp
    stamps, poses = stamps[keep], poses[keep]
    if stamps.size >= 2:
        step = np.hypot(np.diff(poses[:, 0]), np.diff(poses[:, 1]))
        dt = np.diff(stamps) / 1e9
        fast = np.flatnonzero(step > MAX_SPEED * np.maximum(dt, 0.05))
        if fast.size:
            i = int(fast[0])
            raise _fail(
                bag,
                f"topic {topic}: the odometry jumps {step[i]:.3g} m in {dt[i]:.3g} s between stamps {stamps[i]} and "
                f"{stamps[i + 1]} ns (more than {MAX_SPEED:g} m/s); the recording's odometry cannot be trusted",
            )
    return stamps, poses
