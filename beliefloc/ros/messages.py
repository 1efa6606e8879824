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


# --- recordings: the messages a run is written as (beliefloc.recordings) ---------------------------
#
# - ``geometry_msgs/msg/TransformStamped``: ``Header header; string child_frame_id; Transform transform``
#   (``Vector3 translation; Quaternion rotation``); ``tf2_msgs/msg/TFMessage``: ``TransformStamped[] transforms``
# - ``nav_msgs/msg/Odometry``: ``Header header; string child_frame_id; PoseWithCovariance pose;
#   TwistWithCovariance twist`` (the twist in ``child_frame_id``)
# - ``sensor_msgs/msg/LaserScan``: ``Header header; float32 angle_min, angle_max, angle_increment,
#   time_increment, scan_time, range_min, range_max; float32[] ranges, intensities`` (REP 117 readings)
# - ``nav_msgs/msg/OccupancyGrid``: ``Header header; MapMetaData info; int8[] data``, ``info`` being
#   ``Time map_load_time; float32 resolution; uint32 width, height; Pose origin``; ``data`` row-major
#   from the cell at ``origin`` (row 0 is the bottom of the map), 0 free, 100 occupied, -1 unknown
# - ``visualization_msgs/msg/Marker``: type 6 ``CUBE_LIST`` draws a cube of ``scale`` at each of
#   ``points`` in the colour of the same index of ``colors`` (``std_msgs/ColorRGBA``, 0..1)


def transform_stamped(parent: str, child: str, p: Pose, ns: int = 0) -> Message:
    """A ``geometry_msgs/msg/TransformStamped``: frame ``child`` at pose ``p`` in frame ``parent``."""
    return {
        "header": header(parent, ns),
        "child_frame_id": child,
        "transform": {"translation": {"x": p.x, "y": p.y, "z": 0.0}, "rotation": yaw_quaternion(p.yaw)},
    }


def tf_message(transforms: Iterable[Message]) -> Message:
    """A ``tf2_msgs/msg/TFMessage`` (the body of ``/tf`` and ``/tf_static``)."""
    return {"transforms": list(transforms)}


def odometry(
    p: Pose,
    ns: int = 0,
    *,
    forward: float = 0.0,
    turn: float = 0.0,
    frame_id: str = "odom",
    child_frame_id: str = "base_link",
) -> Message:
    """A ``nav_msgs/msg/Odometry``: the base's pose ``p`` in ``frame_id`` and its velocity
    (:func:`twist`) in ``child_frame_id``; both covariances zero (unknown)."""
    return {
        "header": header(frame_id, ns),
        "child_frame_id": child_frame_id,
        "pose": {"pose": pose(p), "covariance": [0.0] * 36},
        "twist": {"twist": twist(forward, turn), "covariance": [0.0] * 36},
    }


def laser_scan(
    frame_id: str,
    ns: int,
    *,
    angle_min: float,
    angle_increment: float,
    ranges: Any,
    range_min: float,
    range_max: float,
    time_increment: float = 0.0,
    scan_time: float = 0.0,
    intensities: Any = (),
) -> Message:
    """A ``sensor_msgs/msg/LaserScan`` of ``len(ranges)`` beams from ``angle_min`` (radians,
    counter-clockwise from the frame's +x) every ``angle_increment``; ``angle_max`` is the last
    beam's angle. ``ranges`` (a sequence or a float array) follow REP 117: ``+inf`` no return
    within ``range_max``, NaN no reading."""
    count = len(ranges)
    return {
        "header": header(frame_id, ns),
        "angle_min": angle_min,
        "angle_max": angle_min + angle_increment * (count - 1),
        "angle_increment": angle_increment,
        "time_increment": time_increment,
        "scan_time": scan_time,
        "range_min": range_min,
        "range_max": range_max,
        "ranges": ranges,
        "intensities": intensities,
    }


def occupancy_grid(
    resolution: float, width: int, height: int, origin: Pose, data: Any, frame_id: str = "map", ns: int = 0
) -> Message:
    """A ``nav_msgs/msg/OccupancyGrid`` of ``width x height`` cells of side ``resolution`` (metres),
    whose cell ``(0, 0)``'s outer corner is at ``origin``; ``data`` row-major from there (row 0 at
    the bottom), each 0 (free) to 100 (occupied) or -1 (unknown)."""
    return {
        "header": header(frame_id, ns),
        "info": {
            "map_load_time": stamp(ns),
            "resolution": resolution,
            "width": width,
            "height": height,
            "origin": pose(origin),
        },
        "data": data,
    }


MARKER_CUBE_LIST = 6
"""``visualization_msgs/msg/Marker.CUBE_LIST``."""
MARKER_ADD = 0
"""``visualization_msgs/msg/Marker.ADD`` (also "modify": a marker of the same ns and id is replaced)."""


def cube_list_marker(
    centres: Iterable[tuple[float, float]],
    colours: Iterable[tuple[float, float, float, float]],
    side: float,
    *,
    namespace: str,
    marker_id: int = 0,
    frame_id: str = "map",
    ns: int = 0,
    height: float = 0.01,
) -> Message:
    """A ``visualization_msgs/msg/Marker`` of type ``CUBE_LIST``: a flat square of ``side`` metres
    at each ``(x, y)`` of ``centres`` (on the floor), coloured ``(r, g, b, a)`` in 0..1 from
    ``colours``. It replaces the marker of the same ``namespace`` and ``marker_id``."""
    return {
        "header": header(frame_id, ns),
        "ns": namespace,
        "id": marker_id,
        "type": MARKER_CUBE_LIST,
        "action": MARKER_ADD,
        "pose": pose(Pose(0.0, 0.0, 0.0)),
        "scale": {"x": side, "y": side, "z": height},
        "color": {"r": 1.0, "g": 1.0, "b": 1.0, "a": 1.0},
        "points": [{"x": x, "y": y, "z": 0.0} for x, y in centres],
        "colors": [{"r": r, "g": g, "b": b, "a": a} for r, g, b, a in colours],
    }


def marker_array(markers: Iterable[Message]) -> Message:
    """A ``visualization_msgs/msg/MarkerArray``."""
    return {"markers": list(markers)}
