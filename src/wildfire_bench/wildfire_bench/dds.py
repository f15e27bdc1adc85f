"""DDS benchmark: grid fan-out latency across processes and the cost of our layer.

``bench_dds()`` measures, on the loopback-only Cyclone DDS configuration and a domain id of its
own (so it never disturbs a running system or a test session), whatever the backend in use:
it measures our Cyclone layer, so its messages are the layer's classes
(``wildfire_msgs_py.types``), never the rclpy ones the codecs would build by default:

* **grid latency** — a 100x100 ``nav_msgs/OccupancyGrid`` published at 10 Hz by this process
  to ``grid_subscribers`` subscriber processes (separate OS processes, each a full node that
  deserializes the message); latency = receive time - ``header.stamp`` (set just before
  ``publish``, so serialization is included). Target: median < 5 ms.
* **layer overhead** — per-message time of publish + take + deserialize of the same grid,
  in one process, through our rclpy-compatible layer vs raw Cyclone DDS Python with a
  hand-written ``IdlStruct`` mirror of the message. Ratio = ours / raw; target <= 1.5.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from typing import Any

import numpy as np
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import make_idl_struct
from cyclonedds.idl.types import float32, float64, int8, int32, sequence, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

GRID_TOPIC = "/bench/grid"
GRID_SHAPE = (100, 100)


def _bench_domain_id() -> int:
    """A domain of its own: 110..209 from the process id (tests use 1..100)."""
    return 110 + os.getpid() % 100


# --- hand-written raw Cyclone mirror of nav_msgs/OccupancyGrid (the baseline) ------------------
# Built with make_idl_struct from real type objects: with postponed annotations Cyclone cannot
# resolve string annotations of classes defined in a module run as __main__.


def _raw_struct(name: str, typename: str, fields: dict[str, Any]) -> Any:
    return make_idl_struct(name, typename, fields)


RawTime = _raw_struct(
    "Time", "builtin_interfaces::msg::dds_::Time_", {"sec": int32, "nanosec": uint32}
)
RawHeader = _raw_struct(
    "Header", "std_msgs::msg::dds_::Header_", {"stamp": RawTime, "frame_id": str}
)
RawPoint = _raw_struct(
    "Point", "geometry_msgs::msg::dds_::Point_", {"x": float64, "y": float64, "z": float64}
)
RawQuaternion = _raw_struct(
    "Quaternion",
    "geometry_msgs::msg::dds_::Quaternion_",
    {"x": float64, "y": float64, "z": float64, "w": float64},
)
RawPose = _raw_struct(
    "Pose", "geometry_msgs::msg::dds_::Pose_", {"position": RawPoint, "orientation": RawQuaternion}
)
RawMapMetaData = _raw_struct(
    "MapMetaData",
    "nav_msgs::msg::dds_::MapMetaData_",
    {
        "map_load_time": RawTime,
        "resolution": float32,
        "width": uint32,
        "height": uint32,
        "origin": RawPose,
    },
)
# Cyclone's sequence makes an annotation at run time; mypy knows it only inside annotations.
_sequence: Any = sequence
RawOccupancyGrid = _raw_struct(
    "OccupancyGrid",
    "nav_msgs::msg::dds_::OccupancyGrid_",
    {"header": RawHeader, "info": RawMapMetaData, "data": _sequence[int8]},
)


def _raw_grid_message(grid: np.ndarray, stamp_ns: int) -> Any:
    """A raw grid message, every field set explicitly (the raw API has no defaults)."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return RawOccupancyGrid(
        header=RawHeader(stamp=RawTime(sec=sec, nanosec=nanosec), frame_id="map"),
        info=RawMapMetaData(
            map_load_time=RawTime(sec=0, nanosec=0),
            resolution=10.0,
            width=100,
            height=100,
            origin=RawPose(
                position=RawPoint(x=0.0, y=0.0, z=0.0),
                orientation=RawQuaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            ),
        ),
        data=grid.ravel().tolist(),
    )


def _random_grid(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.where(rng.random(GRID_SHAPE) < 0.2, 100, 0).astype(np.int8)


def _raw_roundtrip_s(count: int, domain_id: int) -> float:
    """Mean seconds per grid: raw Cyclone write + take + deserialize, one participant."""
    participant = DomainParticipant(domain_id)
    qos = Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(infinite=True)),
        Policy.History.KeepLast(1),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )
    topic = Topic(participant, "rt/bench/raw_grid", RawOccupancyGrid)
    writer = DataWriter(participant, topic, qos=qos)
    reader = DataReader(participant, topic, qos=qos)
    grid = _random_grid()
    try:
        start = time.perf_counter()
        for i in range(count):
            writer.write(_raw_grid_message(grid, i))
            samples = reader.take(N=1)
            assert samples and len(samples[0].data) == grid.size
            np.asarray(samples[0].data, dtype=np.int8)
        return (time.perf_counter() - start) / count
    finally:
        participant.__del__()


def _layer_roundtrip_s(count: int, domain_id: int) -> float:
    """Mean seconds per grid through our layer: codec + publish + executor + decode."""
    from wildfire_msgs_py.codecs import fire_grid_from_msg, grid_to_msg
    from wildfire_msgs_py.types import get_message
    from wildfire_ros.dds.context import Context
    from wildfire_ros.dds.executor import SingleThreadedExecutor
    from wildfire_ros.dds.node import Node
    from wildfire_ros.dds.qos import QoSProfile

    context = Context()
    context.init([], domain_id=domain_id)
    try:
        node = Node("bench_layer", context=context)
        grid_type = get_message("nav_msgs/msg/OccupancyGrid")
        publisher = node.create_publisher(grid_type, "/bench/layer_grid", QoSProfile(depth=1))
        received: list[Any] = []
        node.create_subscription(
            grid_type,
            "/bench/layer_grid",
            lambda m: received.append(fire_grid_from_msg(m)),
            QoSProfile(depth=1),
        )
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        grid = _random_grid()
        start = time.perf_counter()
        for i in range(count):
            publisher.publish(grid_to_msg(grid, i, message_class=grid_type))
            executor.spin_once(timeout_sec=1.0)
        elapsed = (time.perf_counter() - start) / count
        assert len(received) == count, f"layer benchmark lost messages ({len(received)}/{count})"
        return elapsed
    finally:
        context.shutdown()


def _subscriber_main(expected: int, timeout_s: float, domain_id: int) -> None:
    """Child process: receive grids, print latencies (ms) as JSON on stdout."""
    from wildfire_msgs_py.codecs import grid_from_msg, time_from_msg
    from wildfire_msgs_py.types import get_message
    from wildfire_ros.dds.context import Context
    from wildfire_ros.dds.executor import SingleThreadedExecutor
    from wildfire_ros.dds.node import Node
    from wildfire_ros.dds.qos import QoSProfile

    context = Context()
    context.init([], domain_id=domain_id)
    latencies: list[float] = []

    def grid_callback(msg: Any) -> None:
        now = time.time_ns()
        grid_from_msg(msg)
        latencies.append((now - time_from_msg(msg.header.stamp)) / 1e6)

    node = Node(f"bench_sub_{os.getpid()}", context=context)
    node.create_subscription(
        get_message("nav_msgs/msg/OccupancyGrid"), GRID_TOPIC, grid_callback, QoSProfile(depth=10)
    )
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    print("ready", flush=True)
    end = time.monotonic() + timeout_s
    while len(latencies) < expected and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.1)
    print(json.dumps(latencies), flush=True)
    context.shutdown()


def _grid_latency(subscribers: int, messages: int, domain_id: int) -> list[float]:
    """Publish ``messages`` grids at 10 Hz to subscriber processes; all latencies in ms."""
    from wildfire_msgs_py.codecs import grid_to_msg
    from wildfire_msgs_py.types import get_message
    from wildfire_ros.dds.context import Context
    from wildfire_ros.dds.node import Node
    from wildfire_ros.dds.qos import QoSProfile

    timeout_s = 30.0 + messages * 0.1
    env = dict(os.environ)
    command = [
        sys.executable,
        "-m",
        "wildfire_bench.dds",
        "--subscriber",
        str(messages),
        str(timeout_s),
        str(domain_id),
    ]
    children = [
        subprocess.Popen(command, stdout=subprocess.PIPE, text=True, env=env)
        for _ in range(subscribers)
    ]
    context = Context()
    context.init([], domain_id=domain_id)
    try:
        for child in children:
            assert child.stdout is not None
            if child.stdout.readline().strip() != "ready":
                raise RuntimeError("a benchmark subscriber process failed to start")
        node = Node("bench_pub", context=context)
        grid_type = get_message("nav_msgs/msg/OccupancyGrid")
        publisher = node.create_publisher(grid_type, GRID_TOPIC, QoSProfile(depth=10))
        end = time.monotonic() + 20.0
        while publisher.get_subscription_count() < subscribers and time.monotonic() < end:
            time.sleep(0.05)
        time.sleep(0.5)  # let every reader finish matching before the first sample
        grid = _random_grid()
        next_time = time.monotonic()
        for _ in range(messages):
            publisher.publish(grid_to_msg(grid, time.time_ns(), message_class=grid_type))
            next_time += 0.1
            time.sleep(max(0.0, next_time - time.monotonic()))
        latencies: list[float] = []
        for child in children:
            out, _ = child.communicate(timeout=timeout_s)
            latencies.extend(json.loads(out.strip().splitlines()[-1]))
        return latencies
    finally:
        for child in children:
            if child.poll() is None:
                child.kill()
                child.wait()
        context.shutdown()


def bench_dds(quick: bool = False, smoke: bool = False) -> dict[str, float | int]:
    """Run the DDS benchmarks; ``quick`` shortens them (about 10 s instead of 25 s), ``smoke``
    runs each once at its smallest size (the figures mean nothing)."""
    from wildfire_ros.network_defaults import apply_local_network_defaults

    apply_local_network_defaults()
    domain_id = _bench_domain_id()
    subscribers = 2 if smoke else 8
    messages = 5 if smoke else 30 if quick else 100
    latencies = np.asarray(_grid_latency(subscribers, messages, domain_id))
    roundtrips = 10 if smoke else 100 if quick else 400
    _layer_roundtrip_s(10, domain_id)  # warm-up: type generation, first topic
    layer = _layer_roundtrip_s(roundtrips, domain_id)
    raw = _raw_roundtrip_s(roundtrips, domain_id)
    return {
        "grid_subscribers": subscribers,
        "grid_messages_sent": messages,
        "grid_messages_received": int(latencies.size),
        "grid_latency_median_ms": float(np.median(latencies)) if latencies.size else float("nan"),
        "grid_latency_p95_ms": float(np.percentile(latencies, 95))
        if latencies.size
        else float("nan"),
        "layer_us_per_grid": layer * 1e6,
        "raw_cyclonedds_us_per_grid": raw * 1e6,
        "layer_overhead_ratio": layer / raw,
    }


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "--subscriber":
        _subscriber_main(int(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]))
    else:
        print(json.dumps(bench_dds(quick="--quick" in sys.argv), indent=2))
