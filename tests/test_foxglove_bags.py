"""Our MCAP bags open in Foxglove: every topic of the contract is an MCAP channel with the
schema encoding, message encoding and schema name Foxglove expects of a ROS 2 bag (``ros2msg``
text, ``cdr``, ``pkg/msg/Type``), read by the mcap library's own reader, and the messages
Foxglove draws decode through Foxglove's own ros2msg decoder (mcap-ros2-support) to the
values that were written."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from wildfire_msgs_py import codecs, contract
from wildfire_msgs_py.camera_codec import footprints_to_msg
from wildfire_ros.bag import BagWriter
from wildfire_ros.runtime import serialize_message as serialize

ROS2_TYPE = r"^[a-z0-9_]+/msg/[A-Z][A-Za-z0-9]*$"


def write_bag(path: Path) -> dict[str, object]:
    """A bag of every contract topic (aircraft 0), with the messages the live view shows."""
    burning = np.random.default_rng(3).random((60, 80)) < 0.3
    seen = np.zeros((9, 9), dtype=bool)
    seen[2:7, 3:8] = True
    window = codecs.VisitWindow(20, 30, seen, np.zeros_like(seen))
    messages = {
        contract.FIRE_MAP.name: codecs.fire_grid_to_msg(burning, 2_500_000_000),
        contract.ODOM.resolve(0): codecs.pose_to_odometry((120.0, 340.0, 0.7, 0.2), 0, 100),
        contract.CAMERA_FOOTPRINTS.resolve(0): footprints_to_msg([window], 0, 100),
        contract.SCORE.name: codecs.float64_to_msg(17.0),
    }
    with BagWriter(path) as writer:
        for spec in contract.TOPICS + contract.SYSTEM_TOPICS:
            topic = spec.resolve(0 if spec.per_aircraft else None)
            writer.add_topic(topic, spec.type, transient_local=spec.qos.transient_local)
        for stamp, (topic, message) in enumerate(messages.items()):
            writer.write(topic, 1_000 + stamp, serialize(message))
    return {"burning": burning, "outline": window}


def test_every_channel_is_a_ros2_channel_foxglove_reads(tmp_path: Path) -> None:

    write_bag(tmp_path / "bag")
    with next((tmp_path / "bag").glob("*.mcap")).open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    expected = {
        spec.resolve(0 if spec.per_aircraft else None): spec.type
        for spec in contract.TOPICS + contract.SYSTEM_TOPICS
    }
    channels = {c.topic: c for c in summary.channels.values()}
    assert set(channels) == set(expected)
    for topic, channel in channels.items():
        schema = summary.schemas[channel.schema_id]
        assert channel.message_encoding == "cdr", topic
        assert schema.encoding == "ros2msg", topic
        assert schema.name == expected[topic] and re.match(ROS2_TYPE, schema.name), topic
    # A ros2msg schema carries the definitions it depends on, each after a MSG: line.
    grid_schema = summary.schemas[channels[contract.FIRE_MAP.name].schema_id].data.decode()
    assert "MSG: std_msgs/Header" in grid_schema and "MSG: geometry_msgs/Pose" in grid_schema


def test_foxglove_decoder_reads_back_what_was_written(tmp_path: Path) -> None:
    written = write_bag(tmp_path / "bag")
    decoded = {}
    with next((tmp_path / "bag").glob("*.mcap")).open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for schema, channel, _, message in reader.iter_decoded_messages():
            assert schema is not None
            decoded[channel.topic] = message
    assert set(decoded) == {
        contract.FIRE_MAP.name,
        "/uav0/odom",
        "/uav0/camera/footprints",
        contract.SCORE.name,
    }
    grid = decoded[contract.FIRE_MAP.name]
    assert (grid.info.width, grid.info.height, grid.info.resolution) == (80, 60, 10.0)
    assert (grid.header.stamp.sec, grid.header.stamp.nanosec, grid.header.frame_id) == (
        2,
        500_000_000,
        "map",
    )
    cells = np.asarray(grid.data, dtype=np.int8).reshape(60, 80)
    np.testing.assert_array_equal(cells == 100, written["burning"])
    odom = decoded["/uav0/odom"]
    assert (odom.pose.pose.position.x, odom.pose.pose.position.y) == (120.0, 340.0)
    assert odom.child_frame_id == "uav0/base_link"
    q = odom.pose.pose.orientation
    assert math.isclose(math.hypot(q.x, q.y, q.z, q.w), 1.0)
    (marker,) = decoded["/uav0/camera/footprints"].markers
    assert marker.header.frame_id == "map" and marker.type == 4  # LINE_STRIP
    xs = [p.x for p in marker.points]
    assert (min(xs), max(xs)) == (330.0, 380.0)  # columns 33..37 of 10 m cells
    assert decoded[contract.SCORE.name].data == 17.0
