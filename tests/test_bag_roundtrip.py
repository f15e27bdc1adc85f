"""rosbag2 MCAP bags: write -> read back independently with rosbags; recorder and Ctrl-C."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.highlevel import AnyReader

from wildfire_msgs_py import codecs
from wildfire_msgs_py.errors import BagError
from wildfire_msgs_py.types import typestore
from wildfire_ros.bag import BagRecorder, BagWriter, bag_info, read_messages
from wildfire_ros.runtime import deserialize_message as deserialize
from wildfire_ros.runtime import get_message
from wildfire_ros.runtime import serialize_message as serialize


def complete_chunk_messages(mcap: Path) -> list[Any]:
    """Messages of the chunks of a (growing or truncated) file that the reference reader
    decodes whole, CRC checked; stops at the first partial record."""
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader, breakup_chunk

    messages = []
    with mcap.open("rb") as stream:
        records = StreamReader(stream, validate_crcs=True, emit_chunks=True).records
        while True:
            try:
                record = next(records)
                inner = (
                    breakup_chunk(record, validate_crc=True) if isinstance(record, Chunk) else []
                )
            except Exception:  # the partial end, whatever it raises
                return messages
            messages += [r for r in inner if hasattr(r, "sequence")]


def _write_sample_bag(path: Path) -> tuple[np.ndarray, list[np.ndarray]]:
    grid = np.random.default_rng(7).random((100, 100)) < 0.25
    states = [np.array([i * 10.0, 5.0, 0.25 * i, -0.1]) for i in range(4)]
    with BagWriter(path) as writer:
        writer.add_topic(
            "/wildfire/fire_map", "nav_msgs/msg/OccupancyGrid", transient_local=True, depth=1
        )
        writer.add_topic("/uav0/state", "std_msgs/msg/Float64MultiArray")
        for i, state in enumerate(states):
            writer.write("/uav0/state", 2_000 + 10 * i, serialize(codecs.state_to_msg(state)))
        writer.write("/wildfire/fire_map", 1_000, serialize(codecs.fire_grid_to_msg(grid, 1_000)))
    return grid, states


def test_written_bag_is_read_by_rosbags_anyreader(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    grid, states = _write_sample_bag(bag)
    assert (bag / "metadata.yaml").is_file() and len(list(bag.glob("*.mcap"))) == 1
    assert "storage_identifier: mcap" in (bag / "metadata.yaml").read_text()
    with AnyReader([bag], default_typestore=typestore()) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == {
            "/wildfire/fire_map": "nav_msgs/msg/OccupancyGrid",
            "/uav0/state": "std_msgs/msg/Float64MultiArray",
        }
        assert (
            "int8[] data"
            in next(c for c in reader.connections if c.topic == "/wildfire/fire_map").msgdef.data
        )
        decoded = [
            (c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()
        ]
    assert [t for _, t, _ in decoded] == [1_000, 2_000, 2_010, 2_020, 2_030]
    np.testing.assert_array_equal(codecs.fire_grid_from_msg(decoded[0][2]), grid)
    np.testing.assert_array_equal(codecs.state_from_msg(decoded[-1][2]), states[-1])


def test_read_messages_in_time_order_and_filtered(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    grid, states = _write_sample_bag(bag)
    messages = list(read_messages(bag))
    assert [m.time_ns for m in messages] == sorted(m.time_ns for m in messages)
    assert messages[0].topic == "/wildfire/fire_map"
    only_state = list(read_messages(bag, topics=["/uav0/state"]))
    assert [m.type for m in only_state] == ["std_msgs/msg/Float64MultiArray"] * 4
    for message, state in zip(only_state, states, strict=True):
        assert codecs.state_from_msg(message.message).tobytes() == state.tobytes()
    raw = next(read_messages(bag, topics=["/wildfire/fire_map"], raw=True))
    # Raw mode hands back the CDR bytes as written. They are compared decoded: Fast CDR leaves
    # alignment padding uninitialised, so two serializations of one message may differ.
    assert isinstance(raw.message, bytes)
    decoded = deserialize(raw.message, get_message("nav_msgs/msg/OccupancyGrid"))
    np.testing.assert_array_equal(codecs.fire_grid_from_msg(decoded), grid)
    info = bag_info(bag)
    assert info.message_count == 5 and info.duration_s == pytest.approx(1_030 / 1e9)
    assert [(t.name, t.message_count) for t in info.topics] == [
        ("/uav0/state", 4),
        ("/wildfire/fire_map", 1),
    ]


def test_bad_bags_raise_bag_error(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="no such directory"):
        bag_info(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(BagError, match="expected a rosbag2 directory"):
        list(read_messages(tmp_path / "empty"))
    bag = tmp_path / "run"
    _write_sample_bag(bag)
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [not, a, mapping\n")
    with pytest.raises(BagError, match="corrupt"):
        bag_info(bag)
    with pytest.raises(BagError, match="already exists"):
        BagWriter(bag)
    good = tmp_path / "good"
    _write_sample_bag(good)
    with pytest.raises(BagError, match="no topic /nope"):
        list(read_messages(good, topics=["/nope"]))


@pytest.mark.dds
@pytest.mark.timeout(60)
def test_recorder_records_all_topics_including_late_ones(ros_runtime: Any, tmp_path: Path) -> None:
    rt = ros_runtime
    sim = rt.Node("fire_sim")
    fire = sim.create_publisher(
        rt.get_message("nav_msgs/msg/OccupancyGrid"), "/wildfire/fire_map", codecs_qos()
    )
    grid = np.eye(100, dtype=bool)
    fire.publish(codecs.fire_grid_to_msg(grid, 5))  # before the recorder exists: latched
    recorder = BagRecorder(tmp_path / "rec", discovery_period=0.1)
    executor = rt.SingleThreadedExecutor()
    executor.add_node(sim)
    executor.add_node(recorder.node)
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
    score = sim.create_publisher(rt.get_message("std_msgs/msg/Float64"), "/wildfire/score", 10)
    end = time.monotonic() + 10.0
    sent = 0
    while time.monotonic() < end and recorder.message_count < 4:
        if sent < 3:
            score.publish(codecs.score_to_msg(float(sent)))
            sent += 1
        executor.spin_once(timeout_sec=0.2)
    executor.shutdown()
    recorder.close()
    messages = list(read_messages(tmp_path / "rec"))
    topics = [m.topic for m in messages]
    assert topics.count("/wildfire/fire_map") == 1
    np.testing.assert_array_equal(codecs.fire_grid_from_msg(messages[0].message), grid)
    assert 1 <= topics.count("/wildfire/score") <= 3  # discovered late: first ones may be missed


def codecs_qos() -> Any:
    from wildfire_msgs_py.contract import FIRE_MAP
    from wildfire_ros.runtime import qos_profile

    return qos_profile(FIRE_MAP.qos)


WILDFIRE = [
    sys.executable,
    "-c",
    "import sys; from wildfire_cli import main; sys.exit(main())",
]
PUBLISHER = """
import sys, time
from wildfire_msgs_py import codecs
from wildfire_ros.runtime import Node, get_message, rclpy
rclpy.init(args=[])
node = Node("scorer")
pub = node.create_publisher(get_message("std_msgs/msg/Float64"), "/wildfire/score", 10)
print("ready", flush=True)
for i in range(3000):  # up to a minute: the test stops it, however slow the recorder starts
    pub.publish(codecs.score_to_msg(float(i)))
    time.sleep(0.02)
rclpy.shutdown()
"""


@pytest.mark.dds
@pytest.mark.timeout(180)
@pytest.mark.parametrize("stop_signal", [signal.SIGINT, signal.SIGTERM])
def test_signal_during_recording_leaves_readable_bag(
    tmp_path: Path, dds_env: dict[str, str], stop_signal: signal.Signals
) -> None:
    bag = tmp_path / "signalled"
    publisher = subprocess.Popen(
        [sys.executable, "-c", PUBLISHER], env=dds_env, stdout=subprocess.PIPE, text=True
    )
    recorder = None
    try:
        assert publisher.stdout is not None and publisher.stdout.readline().strip() == "ready"
        recorder = subprocess.Popen(
            [*WILDFIRE, "bag", "record", "-o", str(bag), "/wildfire/score"],
            env=dds_env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            # As a non-interactive shell starts a background job: SIGINT ignored. The recorder
            # must still stop on it (CI once ran the suite so, and the recorder hung).
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
        )
        # Record for a while: until chunks (closed every second) hold 20 messages.
        end = time.monotonic() + 90
        while time.monotonic() < end and recorder.poll() is None:
            files = list(bag.glob("*.mcap"))
            if files and len(complete_chunk_messages(files[0])) >= 20:
                break
            time.sleep(0.2)
        recorder.send_signal(stop_signal)
        _, err = recorder.communicate(timeout=30)
    finally:
        for process in (publisher, recorder):
            if process is not None and process.poll() is None:
                process.kill()
                process.wait()
    assert recorder.returncode == 0, err
    assert "Recorded" in err and "Traceback" not in err
    scores = [codecs.score_from_msg(m.message) for m in read_messages(bag)]
    assert len(scores) >= 20
    assert scores == sorted(scores) and len(set(scores)) == len(scores)
    with AnyReader([bag], default_typestore=typestore()) as reader:
        assert reader.message_count == len(scores)


@pytest.mark.parametrize("preset", ["none", "zstd_fast", "zstd_small"])
def test_presets_compress_chunks_that_independent_readers_decode(
    tmp_path: Path, preset: str
) -> None:
    from mcap.reader import make_reader
    from mcap.stream_reader import StreamReader

    bag = tmp_path / "run"
    grids = [np.random.default_rng(i).random((100, 100)) < 0.1 for i in range(40)]
    with BagWriter(bag, compression=preset) as writer:
        writer.add_topic(
            "/wildfire/fire_map", "nav_msgs/msg/OccupancyGrid", transient_local=True, depth=1
        )
        for i, grid in enumerate(grids):
            writer.write("/wildfire/fire_map", 10 * i, serialize(codecs.fire_grid_to_msg(grid, i)))
    mcap = next(bag.glob("*.mcap"))
    with mcap.open("rb") as stream:
        summary = make_reader(stream).get_summary()
        assert summary is not None
        kinds = {index.compression for index in summary.chunk_indexes}
        stream.seek(0)
        messages = [
            r for r in StreamReader(stream, validate_crcs=True).records if hasattr(r, "sequence")
        ]
    assert kinds == ({""} if preset == "none" else {"zstd"})
    assert [m.sequence for m in messages] == list(range(1, 41))
    info = bag_info(bag)
    assert info.preset == preset and info.message_count == 40
    if preset != "none":
        assert info.compression_ratio > 5  # sparse grids: zstd must do far better than raw
    with AnyReader([bag], default_typestore=typestore()) as reader:
        decoded = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    for grid, message in zip(grids, decoded, strict=True):
        np.testing.assert_array_equal(codecs.fire_grid_from_msg(message), grid)


def test_metadata_is_jazzy_with_type_hashes_and_offered_qos(tmp_path: Path) -> None:
    import yaml
    from mcap.reader import make_reader

    bag = tmp_path / "run"
    _write_sample_bag(bag)
    information = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert information["version"] == 9 and information["ros_distro"] == "jazzy"
    topics = {
        t["topic_metadata"]["name"]: t["topic_metadata"]
        for t in information["topics_with_message_count"]
    }
    fire = topics["/wildfire/fire_map"]
    # The hash ROS 2 Jazzy computes for nav_msgs/msg/OccupancyGrid (rclpy reports the same).
    expected = "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"
    assert fire["type_description_hash"] == expected
    assert fire["offered_qos_profiles"][0]["durability"] == "transient_local"
    assert fire["offered_qos_profiles"][0]["depth"] == 1
    with next(bag.glob("*.mcap")).open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    channels = {c.topic: c.metadata for c in summary.channels.values()}
    assert channels["/wildfire/fire_map"]["topic_type_hash"] == expected
    assert "transient_local" in channels["/wildfire/fire_map"]["offered_qos_profiles"]
    info = bag_info(bag)
    assert {t.name: t.type_hash for t in info.topics}["/wildfire/fire_map"] == expected
    sizes = {t.name: t.size_bytes for t in info.topics}
    assert sizes["/wildfire/fire_map"] > 10_000 and 0 < sizes["/uav0/state"] < 1_000


@pytest.mark.dds
@pytest.mark.timeout(60)
def test_type_hash_is_the_one_rclpy_reports(ros_runtime: Any) -> None:
    from wildfire_ros.bag import type_hash

    if ros_runtime.BACKEND != "rclpy":
        pytest.skip("the DDS backend does not compute type hashes")
    node = ros_runtime.Node("hash_check")
    for name in ("nav_msgs/msg/OccupancyGrid", "sensor_msgs/msg/JointState", "std_msgs/msg/Header"):
        topic = "/hash_check/" + name.split("/")[-1].lower()
        node.create_publisher(ros_runtime.get_message(name), topic, 1)
        (endpoint,) = node.get_publishers_info_by_topic(topic)
        assert str(endpoint.topic_type_hash) == type_hash(name)
    node.destroy_node()


@pytest.mark.dds
@pytest.mark.timeout(60)
def test_sim_time_recorder_logs_clock_time(ros_runtime: Any, tmp_path: Path) -> None:
    rt = ros_runtime
    sim = rt.Node("clocked")
    clock = sim.create_publisher(
        rt.get_message("rosgraph_msgs/msg/Clock"), "/clock", codecs_clock_qos()
    )
    score = sim.create_publisher(rt.get_message("std_msgs/msg/Float64"), "/wildfire/score", 10)
    recorder = BagRecorder(
        tmp_path / "sim", ["/clock", "/wildfire/score"], use_sim_time=True, discovery_period=0.1
    )
    executor = rt.SingleThreadedExecutor()
    executor.add_node(sim)
    executor.add_node(recorder.node)
    end = time.monotonic() + 3.0
    while time.monotonic() < end:  # discovery
        executor.spin_once(timeout_sec=0.05)
    for tick in range(1, 6):
        clock.publish(codecs.clock_to_msg(tick * 100_000_000))
        for _ in range(10):  # the clock first, as the fire simulator publishes it
            executor.spin_once(timeout_sec=0.02)
        score.publish(codecs.score_to_msg(float(tick)))
        end = time.monotonic() + 5.0
        while recorder.message_count < 2 * tick and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    executor.shutdown()
    recorder.close()
    times = {
        m.message.data: m.time_ns for m in read_messages(tmp_path / "sim", ["/wildfire/score"])
    }
    assert times == {float(t): t * 100_000_000 for t in range(1, 6)}
    assert bag_info(tmp_path / "sim").time_source == "sim"


def codecs_clock_qos() -> Any:
    from wildfire_msgs_py.contract import CLOCK
    from wildfire_ros.runtime import qos_profile

    return qos_profile(CLOCK.qos)
