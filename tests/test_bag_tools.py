"""``wildfire bag play|convert|reindex|info``: replay heard by a recorder, repairs, bad input."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from test_bag_roundtrip import complete_chunk_messages
from wildfire_msgs_py import codecs, contract
from wildfire_msgs_py.errors import BagError
from wildfire_msgs_py.types import typestore
from wildfire_ros.bag import BagWriter, bag_info, read_messages
from wildfire_ros.bag_repair import reindex
from wildfire_ros.runtime import serialize_message as serialize

WILDFIRE = str(Path(sys.executable).with_name("wildfire"))


def _wildfire(*args: str, env: dict[str, str] | None = None, timeout: float = 120) -> Any:
    return subprocess.run(
        [WILDFIRE, *args], capture_output=True, text=True, timeout=timeout, env=env, check=False
    )


def _one_line_error(done: Any, *fragments: str) -> None:
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().count("\n") == 0 and "Traceback" not in done.stderr
    for fragment in fragments:
        assert fragment in done.stderr


def _write_lockstep_bag(path: Path, ticks: int = 30) -> None:
    """A small lockstep-like bag: latched maps, /clock, per-aircraft streams (sim time)."""
    rng = np.random.default_rng(3)
    with BagWriter(path, custom_data={"wildfire.time_source": "sim"}) as writer:
        for spec in (contract.CLOCK, contract.FIRE_MAP, contract.SCORE):
            q = spec.qos
            writer.add_topic(
                spec.name,
                spec.type,
                reliable=q.reliable,
                transient_local=q.transient_local,
                depth=q.depth,
            )
        writer.add_topic(contract.STATE.resolve(0), contract.STATE.type)
        burning = rng.random((100, 100)) < 0.05
        writer.write(contract.FIRE_MAP.name, 0, serialize(codecs.fire_grid_to_msg(burning, 0)))
        for tick in range(1, ticks + 1):
            t = tick * 20_000_000  # 50 Hz of sim time: the bag plays in 0.6 s
            writer.write(contract.CLOCK.name, t, serialize(codecs.clock_to_msg(t)))
            state = np.array([tick * 1.5, 2.0, 0.1 * tick, 0.0])
            writer.write(contract.STATE.resolve(0), t, serialize(codecs.state_to_msg(state)))
            writer.write(contract.SCORE.name, t, serialize(codecs.score_to_msg(float(tick))))


def test_reindex_recovers_every_complete_chunk(tmp_path: Path) -> None:
    bag = tmp_path / "killed"
    writer = BagWriter(bag)
    writer.add_topic("/wildfire/score", "std_msgs/msg/Float64")
    writer.add_topic("/wildfire/fire_map", "nav_msgs/msg/OccupancyGrid")
    grid = np.random.default_rng(0).random((100, 100)) < 0.5
    for i in range(200):
        writer.write("/wildfire/score", i, serialize(codecs.score_to_msg(float(i))))
        writer.write("/wildfire/fire_map", i, serialize(codecs.fire_grid_to_msg(grid, i)))
        if i % 50 == 49:
            writer.flush_if_due()
    # What a SIGKILL leaves: no summary, no metadata.yaml, the last chunk cut short.
    writer._file.close()
    data = writer.mcap_path.read_bytes()
    writer.mcap_path.write_bytes(data[: len(data) - 1000])
    expected = complete_chunk_messages(writer.mcap_path)
    assert 0 < len(expected) < 400

    with pytest.raises(BagError, match=r"no metadata\.yaml next to killed_0\.mcap.*reindex"):
        bag_info(bag)
    result = reindex(bag)
    assert not result.complete and result.messages == len(expected)
    assert result.kept_original is not None and result.kept_original.is_file()
    recovered = list(read_messages(bag, raw=True))
    assert [m.message for m in recovered] == [m.data for m in expected]
    info = bag_info(bag)
    assert info.compression == "zstd" and info.ros_distro == "jazzy"


def test_convert_recompresses_and_keeps_every_record(tmp_path: Path) -> None:
    source = tmp_path / "fast"
    _write_lockstep_bag(source, ticks=200)
    done = _wildfire(
        "bag", "convert", str(source), str(tmp_path / "none"), "--compression", "none", "--json"
    )
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["messages"] == bag_info(source).message_count == 601
    assert summary["output_bytes"] > summary["input_bytes"]
    before = list(read_messages(source, raw=True))
    after = list(read_messages(tmp_path / "none", raw=True))
    assert [(m.topic, m.time_ns, m.message) for m in after] == [
        (m.topic, m.time_ns, m.message) for m in before
    ]
    info = bag_info(tmp_path / "none")
    assert info.compression == "" and info.preset == "none" and info.time_source == "sim"
    _one_line_error(
        _wildfire("bag", "convert", str(source), str(tmp_path / "none")), "already exists"
    )


def test_bad_bags_are_named_in_one_line(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    _one_line_error(_wildfire("bag", "info", str(tmp_path / "empty")), "empty", "metadata.yaml")
    _one_line_error(_wildfire("bag", "play", str(tmp_path / "nope")), "no such directory")
    bag = tmp_path / "cut"
    _write_lockstep_bag(bag)
    mcap = next(bag.glob("*.mcap"))
    mcap.write_bytes(mcap.read_bytes()[:-200])  # summary gone, metadata.yaml still there
    for verb in ("info", "play"):
        _one_line_error(_wildfire("bag", verb, str(bag)), "cut_0.mcap", "truncated", "reindex")
    _one_line_error(_wildfire("bag", "reindex", str(tmp_path / "empty")), "found none")
    done = _wildfire("bag", "reindex", str(bag), "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["messages"] == 91
    _one_line_error(_wildfire("bag", "play", str(bag), "--topics", "/nope"), "no topic /nope")


PUBLISHER = """
import time
from wildfire_msgs_py import codecs
from wildfire_ros.runtime import Node, get_message, rclpy
rclpy.init(args=[])
node = Node("scorer")
pub = node.create_publisher(get_message("std_msgs/msg/Float64"), "/wildfire/score", 100)
print("ready", flush=True)
for i in range(6000):
    pub.publish(codecs.score_to_msg(float(i)))
    time.sleep(0.01)
"""


@pytest.mark.dds
@pytest.mark.slow
@pytest.mark.timeout(180)
def test_sigkill_during_recording_loses_only_the_open_chunk(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    bag = tmp_path / "killed"
    publisher = subprocess.Popen(
        [sys.executable, "-c", PUBLISHER], env=dds_env, stdout=subprocess.PIPE, text=True
    )
    recorder = None
    try:
        assert publisher.stdout is not None and publisher.stdout.readline().strip() == "ready"
        recorder = subprocess.Popen(
            [WILDFIRE, "bag", "record", "-o", str(bag), "/wildfire/score"],
            env=dds_env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        mcap = bag / "killed_0.mcap"
        end = time.monotonic() + 60
        # Chunks close every second: wait until three are on disk, then kill mid-recording.
        while time.monotonic() < end and recorder.poll() is None:
            if mcap.is_file() and len(complete_chunk_messages(mcap)) > 0:
                time.sleep(3.0)
                break
            time.sleep(0.2)
        assert recorder.poll() is None, recorder.communicate()[1]
        os.kill(recorder.pid, signal.SIGKILL)
        recorder.wait(timeout=30)
    finally:
        for process in (publisher, recorder):
            if process is not None and process.poll() is None:
                process.kill()
                process.wait()
    assert not (bag / "metadata.yaml").exists()
    flushed = complete_chunk_messages(mcap)
    assert len(flushed) >= 100  # about 3 s at 100 Hz were in closed chunks

    _one_line_error(_wildfire("bag", "info", str(bag), env=dds_env), "killed_0.mcap", "reindex")
    done = _wildfire("bag", "reindex", str(bag), "--json", env=dds_env)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["messages"] == len(flushed)
    scores = [codecs.score_from_msg(m.message) for m in read_messages(bag)]
    assert [serialize(codecs.score_to_msg(s)) for s in scores] == [m.data for m in flushed]
    assert scores == [scores[0] + i for i in range(len(scores))]  # reliable: none missing
    assert [m.sequence for m in flushed] == list(range(1, len(flushed) + 1))


def _backend_pairs() -> list[tuple[str, str]]:
    active = os.environ["WILDFIRE_ROS_BACKEND"]
    pairs = [(active, active)]
    if active == "rclpy":
        pairs.append(("rclpy", "dds"))  # Fast DDS player heard by a Cyclone DDS recorder
    return pairs


@pytest.mark.dds
@pytest.mark.slow
@pytest.mark.timeout(240)
@pytest.mark.parametrize(("player_backend", "recorder_backend"), _backend_pairs())
def test_play_is_heard_message_by_message_by_a_recorder(
    tmp_path: Path, dds_env: dict[str, str], player_backend: str, recorder_backend: str
) -> None:
    source = tmp_path / "source"
    _write_lockstep_bag(source)
    heard = tmp_path / "heard"
    recorder = subprocess.Popen(
        [WILDFIRE, "bag", "record", "-a", "-o", str(heard)],
        env={**dds_env, "WILDFIRE_ROS_BACKEND": recorder_backend},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        end = time.monotonic() + 60
        while not heard.is_dir() and time.monotonic() < end and recorder.poll() is None:
            time.sleep(0.1)
        played = _wildfire(
            "bag",
            "play",
            str(source),
            "--wait-for-subscribers",
            "--delay",
            "1",
            "--json",
            env={**dds_env, "WILDFIRE_ROS_BACKEND": player_backend},
            timeout=120,
        )
        assert played.returncode == 0, played.stderr
        assert json.loads(played.stdout)["published"] == 91
        time.sleep(1.0)
        recorder.send_signal(signal.SIGINT)
        _, err = recorder.communicate(timeout=60)
        assert recorder.returncode == 0, err
    finally:
        if recorder.poll() is None:
            recorder.kill()
            recorder.wait()
    expected: dict[str, list[bytes]] = {}
    for m in read_messages(source, raw=True):
        expected.setdefault(m.topic, []).append(m.message)
    got: dict[str, list[bytes]] = {}
    for m in read_messages(heard, raw=True):
        if m.topic in expected:
            got.setdefault(m.topic, []).append(m.message)
    assert {t: len(v) for t, v in got.items()} == {t: len(v) for t, v in expected.items()}
    store = typestore()

    def normalized(bag: Path, topic: str) -> list[bytes]:
        # CDR alignment padding is not part of a message: rclpy's serializer leaves it
        # uninitialized, so payloads are compared as rosbags re-serializes them.
        return [bytes(store.serialize_cdr(m.message, m.type)) for m in read_messages(bag, [topic])]

    for topic, payloads in expected.items():
        assert normalized(heard, topic) == normalized(source, topic), topic
        if player_backend == recorder_backend == "rclpy":
            assert got[topic] == payloads, topic  # rclpy publishes the recorded bytes as they are
    info = {t.name: t for t in bag_info(heard).topics}
    assert info[contract.FIRE_MAP.name].offered_qos[0].transient_local


def test_playback_qos_follows_the_recorded_offers() -> None:
    from wildfire_ros.bag import QosSummary
    from wildfire_ros.bag_play import VOLATILE_MIN_DEPTH, playback_qos

    latched = QosSummary(reliable=True, transient_local=True, depth=1)
    assert playback_qos([latched], "/wildfire/fire_map") == latched  # stays latched, depth 1
    mixed = [latched, QosSummary(reliable=False, transient_local=False, depth=5)]
    assert playback_qos(mixed, "/x") == QosSummary(False, False, VOLATILE_MIN_DEPTH)
    assert playback_qos([], "/wildfire/belief") == QosSummary(True, True, 1)  # the contract's
    assert playback_qos([], "/unknown") == QosSummary(True, False, 10)
