"""ROS message bodies: the plain-data shapes and their conversion to rosbags messages, which must
survive a CDR round trip field by field."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beliefloc.pose import Pose, PoseEstimate
from beliefloc.ros.messages import header, pose_array, pose_with_covariance_stamped, stamp, to_typed, twist

rosbags_typesys = pytest.importorskip("rosbags.typesys")


@pytest.fixture(scope="module")
def typestore():  # type: ignore[no-untyped-def]
    return rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_HUMBLE)


def test_stamp_splits_nanoseconds() -> None:
    assert stamp(0) == {"sec": 0, "nanosec": 0}
    assert stamp(1_700_000_000_123_456_789) == {"sec": 1_700_000_000, "nanosec": 123_456_789}
    assert header("map", 2_500_000_000) == {"stamp": {"sec": 2, "nanosec": 500_000_000}, "frame_id": "map"}


def test_twist_is_planar() -> None:
    assert twist() == {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    body = twist(0.2, -0.5)
    assert body["linear"]["x"] == 0.2 and body["angular"]["z"] == -0.5


def test_pose_array_round_trips_through_cdr(typestore) -> None:  # type: ignore[no-untyped-def]
    poses = [Pose(1.0, -2.5, 0.0), Pose(0.25, 3.0, math.pi / 2), Pose(-1.0, 0.0, -3.0)]
    msgtype = "geometry_msgs/msg/PoseArray"
    typed = to_typed(typestore, msgtype, pose_array(poses, "map", 3_000_000_007))
    back = typestore.deserialize_cdr(typestore.serialize_cdr(typed, msgtype), msgtype)
    assert back.header.frame_id == "map" and (back.header.stamp.sec, back.header.stamp.nanosec) == (3, 7)
    assert len(back.poses) == 3
    for p, got in zip(poses, back.poses, strict=True):
        assert (got.position.x, got.position.y, got.position.z) == (p.x, p.y, 0.0)
        yaw = 2 * math.atan2(got.orientation.z, got.orientation.w)
        assert math.remainder(yaw - p.yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_pose_with_covariance_round_trips(typestore) -> None:  # type: ignore[no-untyped-def]
    covariance = tuple(float(i) / 10 for i in range(36))
    estimate = PoseEstimate(Pose(1.5, 2.0, 1.0), covariance, 3, 0.9)
    msgtype = "geometry_msgs/msg/PoseWithCovarianceStamped"
    typed = to_typed(typestore, msgtype, pose_with_covariance_stamped(estimate, "map", 5))
    back = typestore.deserialize_cdr(typestore.serialize_cdr(typed, msgtype), msgtype)
    assert np.array_equal(back.pose.covariance, np.array(covariance))
    assert back.pose.pose.position.x == 1.5 and back.header.stamp.nanosec == 5


def test_missing_fields_get_ros_defaults_and_unknown_fields_are_refused(typestore) -> None:  # type: ignore[no-untyped-def]
    scan = to_typed(typestore, "sensor_msgs/msg/LaserScan", {"ranges": [1.0, math.inf]})
    assert scan.header.frame_id == "" and scan.angle_min == 0.0 and scan.intensities.size == 0
    assert scan.ranges.dtype == np.float32 and scan.ranges[0] == 1.0 and math.isinf(scan.ranges[1])
    marker = to_typed(typestore, "visualization_msgs/msg/Marker", {"ns": "belief", "type": 1})
    assert marker.ns == "belief" and marker.type == 1 and marker.points == []
    with pytest.raises(KeyError, match="no field colour"):
        to_typed(typestore, "std_msgs/msg/ColorRGBA", {"colour": 1.0})
