"""ROS 2 message bodies as plain data: nested dicts and lists shaped as the ``.msg`` definitions.

One shape serves every way out of beliefloc: ``ros2 topic pub`` reads it as YAML, rosbridge sends it
as JSON, and :func:`to_typed` turns it into a ``rosbags`` message to serialize into a recording.
Pure data, no I/O: times are given in nanoseconds since the epoch by the caller, or as :data:`NOW`,
the word ``ros2 topic pub`` replaces with the time it publishes at (ros2cli's ``set_message_fields``
with ``expand_time_now``); rosbridge and recordings need a number.

Numbers meant for people and ``ros2 topic pub`` go through :func:`rounded`: :data:`DIGITS` decimal
places (nanometres, nanoradians), so that ``1.7999999999999998`` prints as ``1.8``.

Field names follow the ROS 2 message definitions (ros2/common_interfaces, ros2/rcl_interfaces):

- ``builtin_interfaces/msg/Time``: ``int32 sec; uint32 nanosec``
- ``std_msgs/msg/Header``: ``builtin_interfaces/Time stamp; string frame_id``
- ``geometry_msgs/msg/Pose``: ``Point position; Quaternion orientation``
- ``geometry_msgs/msg/PoseWithCovariance``: ``Pose pose; float64[36] covariance``, row-major over
  (x, y, z, rotation about X, rotation about Y, rotation about Z); AMCL reads the yaw variance at 35
- ``geometry_msgs/msg/PoseArray``: ``Header header; Pose[] poses``
- ``geometry_msgs/msg/Twist``: ``Vector3 linear; Vector3 angular``
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any, Literal

from beliefloc.pose import Pose, PoseEstimate

Message = dict[str, Any]
"""A message body: field name to value (a number, a string, a list or a nested body)."""

NOW: Literal["now"] = "now"
"""A stamp ``ros2 topic pub`` fills in with the time it publishes at."""
Stamp = int | Literal["now"]
"""Nanoseconds since the epoch, or :data:`NOW`."""
DIGITS = 9
"""Decimal places of :func:`rounded`: a nanometre, a nanoradian, 1e-9 m² of covariance."""
TIME = "builtin_interfaces/msg/Time"


def stamp(ns: Stamp) -> Message | str:
    """A ``builtin_interfaces/msg/Time`` for ``ns`` nanoseconds since the epoch (0 means "no time",
    which tf2 reads as the latest transform available), or :data:`NOW` as it is."""
    if ns == NOW:
        return NOW
    seconds, nanoseconds = divmod(int(ns), 1_000_000_000)
    return {"sec": seconds, "nanosec": nanoseconds}


def header(frame_id: str, ns: Stamp = 0) -> Message:
    """A ``std_msgs/msg/Header``."""
    return {"stamp": stamp(ns), "frame_id": frame_id}


def rounded(body: Any, digits: int = DIGITS) -> Any:
    """``body`` with every float rounded to ``digits`` decimal places (half to even, as ``round``),
    and no ``-0.0``; ints, strings and the structure are kept."""
    if isinstance(body, float):
        return round(body, digits) + 0.0
    if isinstance(body, Mapping):
        return {key: rounded(value, digits) for key, value in body.items()}
    if isinstance(body, list):
        return [rounded(value, digits) for value in body]
    return body


def yaw_quaternion(yaw: float) -> Message:
    """The unit quaternion of a rotation by ``yaw`` about +z: ``(0, 0, sin(yaw/2), cos(yaw/2))``."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def pose(p: Pose) -> Message:
    """A ``geometry_msgs/msg/Pose`` on the floor (z = 0)."""
    return {"position": {"x": p.x, "y": p.y, "z": 0.0}, "orientation": yaw_quaternion(p.yaw)}


def pose_with_covariance_stamped(estimate: PoseEstimate, frame_id: str = "map", ns: Stamp = 0) -> Message:
    """A ``geometry_msgs/msg/PoseWithCovarianceStamped``: what Nav2's AMCL reads on ``/initialpose``."""
    return {
        "header": header(frame_id, ns),
        "pose": {"pose": pose(estimate.pose), "covariance": list(estimate.covariance)},
    }


def pose_array(poses: Iterable[Pose], frame_id: str = "map", ns: Stamp = 0) -> Message:
    """A ``geometry_msgs/msg/PoseArray``: e.g. a belief's likely states, to seed a particle filter
    or to draw in RViz."""
    return {"header": header(frame_id, ns), "poses": [pose(p) for p in poses]}


def twist(forward: float = 0.0, turn: float = 0.0) -> Message:
    """A ``geometry_msgs/msg/Twist`` for a planar base: ``forward`` m/s along +x of the robot,
    ``turn`` rad/s counter-clockwise (REP 103). ``twist()`` is the stop command."""
    return {"linear": {"x": forward, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": turn}}


def to_typed(typestore: Any, msgtype: str, body: Mapping[str, Any] | str, now_ns: int | None = None) -> Any:
    """``body`` as a ``rosbags`` message of type ``msgtype`` (e.g. ``"geometry_msgs/msg/PoseArray"``)
    from ``typestore``, ready for ``typestore.serialize_cdr``.

    A field the body leaves out gets ROS's default (0, ``""``, ``False``, empty, or a default nested
    message), as ``ros2 topic pub`` does; a key the message does not have raises ``KeyError``, a
    value that is not a mapping where a message belongs ``TypeError``. A ``builtin_interfaces/Time``
    given as :data:`NOW` becomes ``now_ns`` (``ros2 topic pub``'s publishing time; ``TypeError``
    without one)."""
    import numpy as np
    from rosbags.interfaces import Nodetype

    if msgtype == TIME and body == NOW:
        if now_ns is None:
            raise TypeError(f"{msgtype} given as {NOW!r} needs the time it stands for (now_ns)")
        return to_typed(typestore, msgtype, {"sec": now_ns // 1_000_000_000, "nanosec": now_ns % 1_000_000_000})
    if not isinstance(body, Mapping):
        raise TypeError(f"{msgtype} should be a mapping of its fields, got {body!r}")
    _, fields = typestore.fielddefs[msgtype]
    names = {name for name, _ in fields}
    unknown = set(body) - names
    if unknown:
        raise KeyError(f"{msgtype} has no field {', '.join(sorted(unknown))}")

    def base_default(kind: str) -> Any:
        return "" if kind == "string" else False if kind == "bool" else 0.0 if kind.startswith("float") else 0

    def value(desc: tuple[Any, Any], given: Any) -> Any:
        node, detail = desc
        if node == Nodetype.NAME:
            return to_typed(typestore, detail, given if given is not None else {}, now_ns)
        if node == Nodetype.BASE:
            kind = detail[0]
            if given is None:
                return base_default(kind)
            if kind == "string":
                return str(given)
            return bool(given) if kind == "bool" else float(given) if kind.startswith("float") else int(given)
        (inner_node, inner_detail), length = detail
        if inner_node == Nodetype.BASE and inner_detail[0] not in ("string", "bool"):
            data = np.asarray(given if given is not None else [], dtype=inner_detail[0])
            if node == Nodetype.ARRAY and given is None:
                data = np.zeros(length, dtype=inner_detail[0])
            return data
        items = list(given) if given is not None else []
        return [value((inner_node, inner_detail), item) for item in items]

    return typestore.types[msgtype](**{name: value(desc, body.get(name)) for name, desc in fields})
