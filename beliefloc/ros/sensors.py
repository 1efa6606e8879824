"""What a robot's topics carry, read from rosbridge's JSON: ``sensor_msgs/LaserScan``,
``nav_msgs/Odometry`` and detections, checked field by field. Pure data, no I/O.

Field names are ROS 2's (``builtin_interfaces/Time``: ``sec``, ``nanosec``); ROS 1's ``secs`` and
``nsecs`` are read too. rosbridge's JSON encoder sends a float that is infinite or NaN as ``null``
(JSON has no such numbers); a ``null`` range is read as REP 117's ``+inf`` (no return).

**Beams by angle.** A map's scan sensor reads ranges at its ``beams`` (degrees clockwise from the
heading; in radians counter-clockwise, REP 103, as :meth:`~beliefloc.robots.readings.ReadingBinner.describe`
gives them). :func:`beam_ranges` picks, for each, the scan's beam nearest in angle, in the laser's
frame, after taking off the laser's yaw on the base (its mount, ``(x, y, yaw)`` in the base frame),
and turns the range into one measured from the base's centre: ``r + x cos θ + y sin θ`` (first order
in the mount's offset: exact for a laser at the centre, within a few millimetres for a laser a few
centimetres off it). A return nearer than ``range_min`` (``-inf``) is a range of 0 (a wall right
there); beyond ``range_max``, ``+inf``, ``null`` or NaN is no wall (``None``).

**Detections** come in two shapes: a ``vision_msgs/Detection2DArray`` (each detection's best
result's class: ``results[].hypothesis.class_id`` since vision_msgs 3 (ROS 2 Humble), ``results[].id``
before; Detection3DArray has the same fields) or a ``std_msgs/String`` whose ``data`` lists the
classes seen, separated by commas or spaces (an empty string: nothing seen).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from beliefloc.errors import ReplyError

SCAN_TYPE = "sensor_msgs/LaserScan"
ODOMETRY_TYPE = "nav_msgs/Odometry"
DETECTION_TYPES = ("vision_msgs/Detection2DArray", "std_msgs/String")
"""The detection messages beliefloc reads (the first is the default)."""


@dataclass(frozen=True)
class Scan:
    """A ``sensor_msgs/LaserScan``: where it was measured and its ranges (``+inf`` for ``null``)."""

    frame_id: str
    stamp_ns: int
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: tuple[float, ...]

    def angle(self, index: int) -> float:
        return self.angle_min + index * self.angle_increment


@dataclass(frozen=True)
class Odometry:
    """A ``nav_msgs/Odometry``: the base's pose ``(x, y, yaw)`` in the odometry frame."""

    frame_id: str
    child_frame_id: str
    stamp_ns: int
    x: float
    y: float
    yaw: float

    @property
    def pose(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.yaw)


def _field(body: Any, path: str, topic: str) -> Any:
    value = body
    for key in path.split("."):
        if not isinstance(value, Mapping) or key not in value:
            raise ReplyError(f"topic {topic}: the message has no field '{path}'")
        value = value[key]
    return value


def _number(body: Any, path: str, topic: str, *, finite: bool = True) -> float:
    value = _field(body, path, topic)
    if isinstance(value, bool) or not isinstance(value, int | float) or (finite and not math.isfinite(value)):
        raise ReplyError(f"topic {topic}: '{path}' should be a finite number, got {value!r}")
    return float(value)


def _stamp_ns(body: Any, topic: str) -> int:
    stamp = _field(body, "header.stamp", topic)
    if isinstance(stamp, Mapping) and "secs" in stamp:  # ROS 1
        sec, nsec = stamp.get("secs"), stamp.get("nsecs", 0)
    elif isinstance(stamp, Mapping):
        sec, nsec = stamp.get("sec"), stamp.get("nanosec", 0)
    else:
        sec, nsec = None, None
    if any(isinstance(v, bool) or not isinstance(v, int) for v in (sec, nsec)):
        raise ReplyError(f"topic {topic}: 'header.stamp' should be {{sec, nanosec}} integers, got {stamp!r}")
    return int(sec) * 1_000_000_000 + int(nsec)  # type: ignore[arg-type]


def _frame(body: Any, path: str, topic: str) -> str:
    value = _field(body, path, topic)
    if not isinstance(value, str):
        raise ReplyError(f"topic {topic}: '{path}' should be a frame name, got {value!r}")
    return value.lstrip("/")


def parse_scan(body: Any, topic: str) -> Scan:
    """A LaserScan body; :class:`ReplyError` naming the topic and field when it is not one."""
    ranges = _field(body, "ranges", topic)
    if not isinstance(ranges, list) or not ranges:
        raise ReplyError(f"topic {topic}: 'ranges' should be a non-empty list of metres, got {str(ranges)[:40]}")
    values = []
    for k, r in enumerate(ranges):
        if r is None:
            values.append(math.inf)
        elif isinstance(r, bool) or not isinstance(r, int | float):
            raise ReplyError(f"topic {topic}: 'ranges[{k}]' should be a number of metres or null, got {r!r}")
        else:
            values.append(float(r))
    increment = _number(body, "angle_increment", topic)
    if increment == 0 and len(values) > 1:
        raise ReplyError(f"topic {topic}: 'angle_increment' is 0 for a scan of {len(values)} beams")
    return Scan(
        _frame(body, "header.frame_id", topic),
        _stamp_ns(body, topic),
        _number(body, "angle_min", topic),
        increment,
        _number(body, "range_min", topic),
        _number(body, "range_max", topic, finite=False),
        tuple(values),
    )


def parse_odometry(body: Any, topic: str) -> Odometry:
    """An Odometry body: the pose's position and the yaw of its orientation."""
    q = [_number(body, f"pose.pose.orientation.{c}", topic) for c in "xyzw"]
    norm = math.sqrt(sum(v * v for v in q))
    if not 0.5 < norm < 1.5:
        raise ReplyError(f"topic {topic}: 'pose.pose.orientation' is not a unit quaternion (norm {norm:.3g})")
    x, y, z, w = q
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return Odometry(
        _frame(body, "header.frame_id", topic),
        _frame(body, "child_frame_id", topic),
        _stamp_ns(body, topic),
        _number(body, "pose.pose.position.x", topic),
        _number(body, "pose.pose.position.y", topic),
        yaw,
    )


def parse_detections(body: Any, topic: str, message_type: str) -> list[str]:
    """The classes a detection message lists (in order, each once)."""
    if message_type == "std_msgs/String":
        data = _field(body, "data", topic)
        if not isinstance(data, str):
            raise ReplyError(f"topic {topic}: 'data' should be the classes seen as text, got {data!r}")
        names = [part for part in data.replace(",", " ").split() if part]
        return list(dict.fromkeys(names))
    detections = _field(body, "detections", topic)
    if not isinstance(detections, list):
        raise ReplyError(f"topic {topic}: 'detections' should be a list, got {str(detections)[:40]}")
    names = []
    for k, detection in enumerate(detections):
        results = detection.get("results") if isinstance(detection, Mapping) else None
        if not isinstance(results, list):
            raise ReplyError(f"topic {topic}: 'detections[{k}].results' should be a list of hypotheses")
        best: tuple[float, str] | None = None
        for j, result in enumerate(results):
            where = f"detections[{k}].results[{j}]"
            hypothesis = result.get("hypothesis", result) if isinstance(result, Mapping) else None
            if not isinstance(hypothesis, Mapping):
                raise ReplyError(f"topic {topic}: '{where}' should be an object hypothesis")
            name = hypothesis.get("class_id", hypothesis.get("id"))
            score = hypothesis.get("score", 1.0)
            if not isinstance(name, str | int) or isinstance(name, bool):
                raise ReplyError(f"topic {topic}: '{where}' has no class ('hypothesis.class_id' or 'id')")
            if isinstance(score, bool) or not isinstance(score, int | float) or not math.isfinite(score):
                raise ReplyError(f"topic {topic}: '{where}.score' should be a finite number, got {score!r}")
            if best is None or score > best[0]:
                best = (float(score), str(name))
        if best is not None:
            names.append(best[1])
    return list(dict.fromkeys(names))


def beam_index(scan: Scan, angle: float) -> int | None:
    """The index of the scan's beam nearest to ``angle`` (radians, laser frame; any turn added or
    taken off), or None when no beam is within half an increment of it."""
    n = len(scan.ranges)
    inc = scan.angle_increment
    for shift in (0.0, 2 * math.pi, -2 * math.pi):
        k = round((angle + shift - scan.angle_min) / inc) if n > 1 else 0
        if 0 <= k < n and abs(scan.angle(k) - angle - shift) <= abs(inc) / 2 + 1e-9:
            return int(k)
    return None


def beam_ranges(
    scan: Scan, beams: Sequence[float], mount: tuple[float, float, float], topic: str
) -> list[float | None]:
    """The ranges of ``beams`` (radians, counter-clockwise in the base frame) from the base's centre,
    as readings the binner takes: metres, or None for no wall (see the module)."""
    mx, my, myaw = mount
    out: list[float | None] = []
    for theta in beams:
        k = beam_index(scan, math.remainder(theta - myaw, 2 * math.pi))
        if k is None:
            end = scan.angle(len(scan.ranges) - 1)
            raise ReplyError(
                f"topic {topic}: the map's beam at {math.degrees(theta):g}° (counter-clockwise from the heading) is "
                f"outside the scan, which covers {math.degrees(scan.angle_min):.4g}° to {math.degrees(end):.4g}° of "
                f"the laser's frame {scan.frame_id!r} (mounted at {math.degrees(myaw):g}° on the base)"
            )
        r = scan.ranges[k]
        if math.isnan(r) or r == math.inf or r > scan.range_max:
            out.append(None)
        elif r < scan.range_min:
            out.append(0.0)
        else:
            out.append(max(r + mx * math.cos(theta) + my * math.sin(theta), 0.0))
    return out


def whole_scan_reading(scan: Scan, mount: tuple[float, float, float], topic: str) -> dict[str, Any]:
    """``scan`` as a whole-scan reading of ``localize``'s protocol (:mod:`beliefloc.robots.readings`):
    the laser's own angles and ranges with its ``mount`` on the base, for a filter that scores the scan
    in full. REP 117: no return (``+inf``), NaN and negative ranges are ``null``; too close (``-inf``)
    is 0 m, below ``range_min`` (a wall right there, skipped by the likelihood field). Raises
    :class:`ReplyError` naming the topic for a scan that cannot be read whole (an infinite
    ``range_max``, ``range_min`` not below it, a zero ``angle_increment``)."""
    if not (math.isfinite(scan.range_max) and 0.0 <= scan.range_min < scan.range_max):
        raise ReplyError(
            f"topic {topic}: a whole scan needs 0 <= range_min < range_max, both finite; got range_min "
            f"{scan.range_min:g}, range_max {scan.range_max:g}"
        )
    if scan.angle_increment == 0:
        raise ReplyError(f"topic {topic}: 'angle_increment' is 0: a whole scan's beams must differ in angle")
    ranges: list[float | None] = []
    for r in scan.ranges:
        if r == -math.inf:
            ranges.append(0.0)
        elif math.isnan(r) or r == math.inf or r < 0:
            ranges.append(None)
        else:
            ranges.append(r)
    return {
        "angle_min": scan.angle_min,
        "angle_increment": scan.angle_increment,
        "ranges": ranges,
        "range_min": scan.range_min,
        "range_max": scan.range_max,
        "mount": list(mount),
    }


def base_points(scan: Scan, mount: tuple[float, float, float]) -> np.ndarray:
    """The scan's returns within range as points in the base frame, shape ``(N, 2)`` (for the
    obstacle stop)."""
    mx, my, myaw = mount
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    angles = scan.angle_min + scan.angle_increment * np.arange(ranges.size) + myaw
    keep = np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges <= scan.range_max)
    r, a = ranges[keep], angles[keep]
    points: np.ndarray = np.stack([mx + r * np.cos(a), my + r * np.sin(a)], axis=1)
    return points
