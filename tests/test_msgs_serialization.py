"""Our DDS-backend CDR bytes equal the rosbags ROS 2 Jazzy serializer's, for every type used."""

from __future__ import annotations

import array

import numpy as np
import pytest

from wildfire_msgs_py import codecs, contract
from wildfire_msgs_py.errors import UnknownMessageTypeError, WildfireRosError
from wildfire_msgs_py.types import (
    dds_type_name,
    deserialize,
    get_message,
    normalize_type_name,
    ros_type_name,
    serialize,
    typestore,
)
from wildfire_ros.runtime import BACKEND

# The codecs build messages of the active backend: these tests of our layer's serializer run
# in the DDS pass of scripts/test.sh (the rclpy pass checks rclpy's bytes in test_msgs_codecs).
pytestmark = [
    pytest.mark.dds,
    pytest.mark.skipif(BACKEND != "dds", reason="tests the Cyclone DDS layer's serializer"),
]

EXTRA_TYPES = [
    "std_msgs/msg/Header",
    "rosgraph_msgs/msg/Clock",
    "std_msgs/msg/String",
    "std_msgs/msg/Float32MultiArray",
    "std_msgs/msg/UInt32",
    "geometry_msgs/msg/PoseStamped",
    "sensor_msgs/msg/Image",
    "diagnostic_msgs/msg/DiagnosticStatus",
]
ALL_TYPES = sorted({spec.type for spec in contract.TOPICS} | set(EXTRA_TYPES))


def _filled(type_name: str) -> object:
    """A message with non-default values in every kind of field (alignment matters)."""
    rng = np.random.default_rng(abs(hash(type_name)) % 2**32)
    grid = np.where(rng.random((100, 100)) < 0.3, 100, 0).astype(np.int8)
    if type_name == "nav_msgs/msg/OccupancyGrid":
        return codecs.grid_to_msg(grid, 1_234_567_891, origin_xy=(-15.0, 30.0))
    if type_name == "nav_msgs/msg/Odometry":
        msg = codecs.pose_to_odometry((512.25, -3.5, 2.9, -0.61), 3, 7_000_000_123)
        msg.pose.covariance = np.arange(36, dtype=np.float64) * 0.5
        return msg
    if type_name == "std_msgs/msg/Float64MultiArray":
        return codecs.state_to_msg((1.0 / 3.0, 2e-9, -np.pi, 0.872664))
    if type_name == "std_msgs/msg/Float64":
        return codecs.score_to_msg(3154.25)
    if type_name == "rosgraph_msgs/msg/Clock":
        return codecs.clock_to_msg(123_456_789_012)
    if type_name == "diagnostic_msgs/msg/DiagnosticArray":
        status = codecs.NodeStatus("uav1/agent: x", "uav1", "WARN", "", {"misses": 3, "ms": 12.5})
        return codecs.diagnostics_to_msg([status], 99)
    msg = get_message(type_name)()
    if type_name == "std_msgs/msg/Header":
        msg.frame_id, msg.stamp.sec, msg.stamp.nanosec = "uav1/base_link", 17, 5
    elif type_name == "std_msgs/msg/String":
        msg.data = "héllo wildfire"
    elif type_name == "std_msgs/msg/Float32MultiArray":
        dim = get_message("std_msgs/msg/MultiArrayDimension")(label="rows", size=3, stride=3)
        msg.layout.dim = [dim]
        msg.data = array.array("f", [1.5, -2.25, 3.0])
    elif type_name == "std_msgs/msg/UInt32":
        msg.data = 4_000_000_000
    elif type_name == "geometry_msgs/msg/PoseStamped":
        msg.header.frame_id = "map"
        msg.pose.position.x, msg.pose.orientation.z = 1.25, 0.5
    elif type_name == "sensor_msgs/msg/Image":
        msg.height, msg.width, msg.encoding, msg.step = 2, 3, "mono8", 3
        msg.data = bytes(range(6))
    elif type_name == "diagnostic_msgs/msg/DiagnosticStatus":
        msg.level, msg.name = msg.ERROR, "x"
    return msg


@pytest.mark.parametrize("type_name", ALL_TYPES)
def test_serialized_bytes_equal_rosbags(type_name: str) -> None:
    msg = _filled(type_name)
    ours = serialize(msg)
    store = typestore()
    reference = store.deserialize_cdr(ours, type_name)  # independent parse of our bytes ...
    assert bytes(store.serialize_cdr(reference, type_name)) == ours  # ... and re-serialization
    assert ours[:4] == b"\x00\x01\x00\x00"  # CDR little endian encapsulation, XCDR1


@pytest.mark.parametrize("type_name", ALL_TYPES)
def test_rosbags_bytes_deserialize_to_equal_message(type_name: str) -> None:
    msg = _filled(type_name)
    store = typestore()
    theirs = bytes(store.serialize_cdr(store.deserialize_cdr(serialize(msg), type_name), type_name))
    back = deserialize(theirs, type(msg))
    assert serialize(back) == theirs


def test_field_values_survive_reference_serializer() -> None:
    msg = _filled("nav_msgs/msg/Odometry")
    parsed = typestore().deserialize_cdr(serialize(msg), "nav_msgs/msg/Odometry")
    assert parsed.child_frame_id == "uav3/base_link"
    assert parsed.pose.pose.position.x == 512.25
    np.testing.assert_array_equal(parsed.pose.covariance, np.arange(36) * 0.5)


def test_rclpy_like_field_types_and_defaults() -> None:
    grid_class = get_message("nav_msgs/msg/OccupancyGrid")
    msg = grid_class()
    assert isinstance(msg.data, array.array) and msg.data.typecode == "b"
    assert msg.info.origin.orientation.w == 1.0  # default from the .msg file
    odom = deserialize(
        serialize(get_message("nav_msgs/msg/Odometry")()), get_message("nav_msgs/msg/Odometry")
    )
    assert isinstance(odom.pose.covariance, np.ndarray) and odom.pose.covariance.shape == (36,)
    status_class = get_message("diagnostic_msgs/msg/DiagnosticStatus")
    assert status_class.WARN == b"\x01"
    assert grid_class.get_fields_and_field_types() == {
        "header": "std_msgs/Header",
        "info": "nav_msgs/MapMetaData",
        "data": "sequence<int8>",
    }
    assert get_message("std_msgs/msg/Float64")(data=2.5).data == 2.5


@pytest.mark.parametrize(
    ("ros", "dds"),
    [
        ("nav_msgs/msg/OccupancyGrid", "nav_msgs::msg::dds_::OccupancyGrid_"),
        ("rosgraph_msgs/msg/Clock", "rosgraph_msgs::msg::dds_::Clock_"),
        ("std_msgs/msg/Float64MultiArray", "std_msgs::msg::dds_::Float64MultiArray_"),
    ],
)
def test_type_name_mangling(ros: str, dds: str) -> None:
    assert dds_type_name(ros) == dds
    assert ros_type_name(dds) == ros
    assert get_message(ros).__idl__.idl_transformed_typename == dds


def test_short_type_names_are_normalized() -> None:
    assert normalize_type_name("std_msgs/String") == "std_msgs/msg/String"
    assert get_message("std_msgs/String") is get_message("std_msgs/msg/String")


@pytest.mark.parametrize("bad", ["std_msgs/msg/Strin", "nonsense", "a/b/c/d", "std_msgs/msg/"])
def test_unknown_types_raise_clear_error(bad: str) -> None:
    with pytest.raises(UnknownMessageTypeError, match="expected") as info:
        get_message(bad)
    assert isinstance(info.value, WildfireRosError)
    assert bad in str(info.value)
    assert ros_type_name("not_a_ros_type") is None
