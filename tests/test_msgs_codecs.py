"""Round trips of the numpy <-> message codecs, the contract helpers and introspection."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wildfire_msgs_py import codecs, contract
from wildfire_msgs_py.errors import MessageFieldError
from wildfire_msgs_py.types import typestore
from wildfire_ros.introspection import message_to_yaml, set_message_fields
from wildfire_ros.runtime import deserialize_message, get_message, serialize_message

# The codecs build messages of the active backend (rclpy's rosidl classes or ours).
pytestmark = pytest.mark.dds


def _wire(msg: object) -> object:
    """The message as a subscriber of the active backend gets it: serialized and deserialized."""
    return deserialize_message(serialize_message(msg), type(msg))


def _rosbags(msg: object, type_name: str) -> object:
    """The message as read back from a bag by rosbags (numpy arrays)."""
    return typestore().deserialize_cdr(serialize_message(msg), type_name)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("via", ["object", "wire", "rosbags"])
def test_fire_grid_round_trip(seed: int, via: str) -> None:
    burning = np.random.default_rng(seed).random((100, 100)) < 0.3
    msg = codecs.fire_grid_to_msg(burning, 5_000_000_000)
    assert msg.info.width == msg.info.height == 100 and msg.info.resolution == 10.0
    assert msg.header.frame_id == "map" and msg.header.stamp.sec == 5
    received = {
        "object": msg,
        "wire": _wire(msg),
        "rosbags": _rosbags(msg, "nav_msgs/msg/OccupancyGrid"),
    }[via]
    np.testing.assert_array_equal(codecs.fire_grid_from_msg(received), burning)


def test_grid_row_zero_is_south() -> None:
    burning = np.zeros((100, 100), dtype=bool)
    burning[0, 7] = True  # south row, 8th column
    msg = codecs.fire_grid_to_msg(burning)
    assert msg.data[7] == 100 and sum(msg.data) == 100


@pytest.mark.parametrize("via", ["object", "wire", "rosbags"])
def test_fuel_grid_stores_value_directly(via: str) -> None:
    fuel = np.random.default_rng(3).integers(0, 21, size=(100, 100))
    msg = codecs.fuel_grid_to_msg(fuel)
    assert int(msg.data[5]) == int(fuel.ravel()[5])
    received = {
        "object": msg,
        "wire": _wire(msg),
        "rosbags": _rosbags(msg, "nav_msgs/msg/OccupancyGrid"),
    }[via]
    np.testing.assert_array_equal(codecs.fuel_grid_from_msg(received), fuel)


def test_belief_age_scaling() -> None:
    ages = np.random.default_rng(4).uniform(0, 300, size=(100, 100))
    msg = codecs.belief_age_to_msg(ages)
    values = codecs.grid_from_msg(msg)
    assert values.min() >= 0 and values.max() <= 100
    back = codecs.belief_age_from_msg(_wire(msg))
    np.testing.assert_allclose(back, np.minimum(ages, 255.0), atol=255 / 200 + 1e-9)


@pytest.mark.parametrize(("row0", "col0"), [(40, 45), (-3, 95), (0, 0)])
def test_visit_window_round_trip(row0: int, col0: int) -> None:
    n = 21
    rows, cols = np.mgrid[0:n, 0:n]
    inside = (rows - 10) ** 2 + (cols - 10) ** 2 <= 100
    rng = np.random.default_rng(row0 + col0)
    window = codecs.VisitWindow(row0, col0, inside, rng.random((n, n)) < 0.5)
    msg = codecs.visit_to_msg(window, 42)
    assert msg.info.origin.position.x == col0 * 10.0
    assert msg.info.origin.position.y == row0 * 10.0
    grid = codecs.grid_from_msg(msg)
    assert set(np.unique(grid[~inside])) == {-1}
    assert set(np.unique(grid[inside])) <= {0, 100}
    assert codecs.visit_from_msg(_wire(msg)) == window
    assert codecs.visit_from_msg(_rosbags(msg, "nav_msgs/msg/OccupancyGrid")) == window


@pytest.mark.parametrize(
    "pose", [(0.0, 0.0, 0.0, 0.0), (512.5, 250.25, 2.5, 0.5), (10.0, 990.0, -3.0, -0.872664)]
)
def test_odometry_round_trip(pose: tuple[float, float, float, float]) -> None:
    msg = codecs.pose_to_odometry(pose, 2, 1_000)
    assert msg.header.frame_id == "map" and msg.child_frame_id == "uav2/base_link"
    assert msg.twist.twist.linear.x == 20.0
    assert math.isclose(msg.twist.twist.angular.z, 9.81 * math.tan(pose[3]) / 20.0)
    q = msg.pose.pose.orientation
    assert math.isclose(q.x**2 + q.y**2 + q.z**2 + q.w**2, 1.0)
    for received in (_wire(msg), _rosbags(msg, "nav_msgs/msg/Odometry")):
        back = codecs.odometry_to_pose(received)
        np.testing.assert_allclose(back, pose, atol=1e-12)


def test_state_is_bit_exact() -> None:
    state = np.array([1.0 / 3.0, np.nextafter(250.0, 300.0), -np.pi + 1e-15, 0.123456789012345])
    msg = codecs.state_to_msg(state)
    for received in (_wire(msg), _rosbags(msg, "std_msgs/msg/Float64MultiArray")):
        assert codecs.state_from_msg(received).tobytes() == state.tobytes()


def test_scalar_clock_time_deadline_codecs() -> None:
    assert codecs.score_from_msg(_wire(codecs.score_to_msg(12.75))) == 12.75
    assert codecs.bank_cmd_from_msg(codecs.bank_cmd_to_msg(-0.5)) == -0.5
    assert [codecs.action_from_msg(codecs.action_to_msg(a)) for a in (0, 1)] == [0, 1]
    ns = 987_654_321_123
    assert codecs.clock_from_msg(_wire(codecs.clock_to_msg(ns))) == ns
    assert codecs.time_from_msg(codecs.time_to_msg(ns)) == ns
    assert codecs.seconds_from_msg(codecs.time_to_msg(1_500_000_000)) == 1.5
    stats = {"decisions": 120, "misses": 2, "worst_ms": 7.25}
    status = codecs.NodeStatus("uav4/agent: decision deadlines", "uav4", "WARN", "2 late", stats)
    msg = _wire(codecs.diagnostics_to_msg([status], ns))
    assert msg.status[0].name == "uav4/agent: decision deadlines"
    assert msg.status[0].level == b"\x01" and msg.status[0].hardware_id == "uav4"
    assert codecs.diagnostics_from_msg(msg) == [status]


def test_decoders_reject_malformed_messages() -> None:
    msg = codecs.fire_grid_to_msg(np.zeros((100, 100), dtype=bool))
    msg.info.width = 99
    with pytest.raises(MessageFieldError, match="expected width\\*height"):
        codecs.grid_from_msg(msg)
    with pytest.raises(MessageFieldError, match="expected 4"):
        codecs.state_from_msg(get_message("std_msgs/msg/Float64MultiArray")(data=[1.0, 2.0]))
    with pytest.raises(ValueError, match=r"0\.\.100"):
        codecs.fuel_grid_to_msg(np.full((2, 2), 200))


def test_contract_names_and_lookup() -> None:
    assert contract.aircraft_topic(0, "odom") == "/uav0/odom"
    assert contract.aircraft_namespace(12) == "/uav12"
    assert contract.aircraft_index("/uav3/visit") == 3
    assert contract.aircraft_index("/wildfire/fire_map") is None
    assert contract.spec_for("/uav7/state") is contract.STATE
    assert contract.spec_for("/wildfire/fire_map") is contract.FIRE_MAP
    assert contract.spec_for("/uav7/unknown") is None
    names = [name for name, _ in contract.topics_for(2)]
    assert "/diagnostics" in names and "/clock" in names and len(names) == 8 + 2 * 5
    assert contract.FIRE_MAP.qos.transient_local and contract.FIRE_MAP.qos.depth == 1
    with pytest.raises(ValueError, match=">= 0"):
        contract.aircraft_namespace(-1)
    for spec in contract.TOPICS:
        get_message(spec.type)  # every contract type exists in the Jazzy type store


def test_contract_qos_profile() -> None:
    from wildfire_ros.runtime import DurabilityPolicy, ReliabilityPolicy, qos_profile

    profile = qos_profile(contract.FIRE_MAP.qos)
    assert profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert profile.reliability == ReliabilityPolicy.RELIABLE and profile.depth == 1


def test_yaml_echo_and_pub_fields() -> None:
    msg = set_message_fields(
        get_message("geometry_msgs/msg/PoseStamped")(),
        {"header": {"frame_id": "map"}, "pose": {"position": {"x": 2}}},
    )
    assert msg.pose.position.x == 2.0 and msg.header.frame_id == "map"
    text = message_to_yaml(codecs.fire_grid_to_msg(np.ones((100, 100), dtype=bool)))
    assert "frame_id: map" in text and text.count("- 100") == 128 and "- '...'" in text
    with pytest.raises(MessageFieldError, match="does not exist"):
        set_message_fields(get_message("std_msgs/msg/String")(), {"dat": "x"})
    with pytest.raises(MessageFieldError, match="expected double"):
        set_message_fields(get_message("std_msgs/msg/Float64")(), {"data": "fast"})
