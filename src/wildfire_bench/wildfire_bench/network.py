"""Network benchmark on virtual hosts (``wildfire bench --only network``; root).

For each ROS runtime backend, every figure in a child process of its own (a participant cannot
leave the namespace it was created in, and each backend is chosen once per process):

* **latency per hop** — a DDS ping-pong between two virtual hosts: this process in host 0
  publishes a ``std_msgs/Header`` (reliable, depth 10) every 50 ms, an echo node in host 1
  publishes it back; one hop = half the round trip, through both runtimes (serialization, the
  executor, UDP over the bridge), on a clean link and with ``delay 20ms 10ms loss 2%``;
* **recovery after a heal** — a real-time run of 2 aircraft on 4 hosts, the aggregator's host
  cut off for a few seconds, then an agent's host: seconds from each heal until the run monitor
  accepts a message of every cut-off node again (the belief for the aggregator, the state for
  an agent). Target <= 3 s.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

BACKENDS = ("rclpy", "dds")
NETEM = "delay 20ms 10ms loss 2%"
PING_TOPIC = "/bench/ping"
PONG_TOPIC = "/bench/pong"
PING_PERIOD_S = 0.05
RECOVERY_TARGET_S = 3.0


def _runtime_node(name: str) -> tuple[Any, Any, Any]:
    """``(runtime, node, Header)`` on this process's backend."""
    from wildfire_ros import runtime

    runtime.rclpy.init(args=[])
    return runtime, runtime.Node(name), runtime.get_message("std_msgs/msg/Header")


def echo_main() -> None:
    """The echo node (host 1): publish back every ping, until stopped."""
    runtime, node, header = _runtime_node("bench_echo")
    publisher = node.create_publisher(header, PONG_TOPIC, runtime.QoSProfile(depth=10))
    node.create_subscription(header, PING_TOPIC, publisher.publish, runtime.QoSProfile(depth=10))
    executor = runtime.SingleThreadedExecutor()
    executor.add_node(node)
    try:
        while True:
            executor.spin_once(timeout_sec=0.1)
    except KeyboardInterrupt:
        pass


def _ping(count: int, discovery_s: float = 60.0) -> dict[str, Any]:
    """Round trips to the echo node; called inside host 0."""
    runtime, node, header = _runtime_node("bench_ping")
    publisher = node.create_publisher(header, PING_TOPIC, runtime.QoSProfile(depth=10))
    returned: dict[int, float] = {}
    node.create_subscription(
        header,
        PONG_TOPIC,
        lambda msg: returned.setdefault(int(msg.frame_id), time.perf_counter()),
        runtime.QoSProfile(depth=10),
    )
    executor = runtime.SingleThreadedExecutor()
    executor.add_node(node)
    sent: dict[int, float] = {}

    def ping(sequence: int) -> None:
        msg = header()
        msg.frame_id = str(sequence)
        sent[sequence] = time.perf_counter()
        publisher.publish(msg)

    # Discovery: ping until one comes back (negative numbers: not measured).
    end, sequence = time.monotonic() + discovery_s, -1
    while not returned and time.monotonic() < end:
        ping(sequence)
        sequence -= 1
        executor.spin_once(timeout_sec=0.2)
    if not returned:
        raise RuntimeError(f"no echo within {discovery_s:g} s (discovery failed)")
    for k in range(count):
        ping(k)
        due = time.perf_counter() + PING_PERIOD_S
        while time.perf_counter() < due:
            executor.spin_once(timeout_sec=max(0.0, due - time.perf_counter()))
    end = time.monotonic() + 2.0
    while time.monotonic() < end and not all(k in returned for k in range(count)):
        executor.spin_once(timeout_sec=0.05)
    runtime.rclpy.try_shutdown()
    hops = np.array([(returned[k] - sent[k]) / 2 * 1e3 for k in range(count) if k in returned])
    return {
        "hop_ms_median": float(np.median(hops)) if hops.size else float("nan"),
        "hop_ms_p95": float(np.percentile(hops, 95)) if hops.size else float("nan"),
        "hop_ms_max": float(hops.max()) if hops.size else float("nan"),
        "pings": count,
        "pongs": int(hops.size),
    }


def ping_main(count: int, netem: str | None) -> dict[str, Any]:
    """Two virtual hosts, the echo node in host 1, round trips from this process in host 0."""
    from wildfire_bringup.launcher import child_environment
    from wildfire_testbed.hosts import VirtualHosts
    from wildfire_testbed.netfaults import NetemSpec

    spec = NetemSpec.parse(netem) if netem else None
    with tempfile.TemporaryDirectory(prefix="wildfire-bench-net-") as tmp:
        network = VirtualHosts(1, 2, Path(tmp), spec)
        with network:
            env = network.environment("uav0", child_environment())
            command = [sys.executable, "-m", "wildfire_bench.network", "--echo"]
            os.environ["ROS_DOMAIN_ID"] = env["ROS_DOMAIN_ID"]
            echo = subprocess.Popen(network.command("uav0", command), env=env)
            try:
                figures = _ping(count)
            finally:
                echo.terminate()
                echo.wait(timeout=10)
        if network.netem_via:
            figures["netem_applied_with"] = network.netem_via
    return figures


def recovery_main(quick: bool, smoke: bool = False) -> dict[str, Any]:
    """Real time on 4 hosts: the aggregator's host cut off, then an agent's; recovery times."""
    from wildfire_bench.system import _spec
    from wildfire_bringup.launcher import Launcher
    from wildfire_testbed.netfaults import Partition

    cut_s = 1.0 if smoke else 4.0 if quick else 10.0
    # The second cut starts 6 s after the first ends, and recovery needs a few seconds after.
    spec = _spec(2, 2 * cut_s + (10.0 if smoke else 12.0), lockstep=False)
    spec.hosts = 4
    spec.partitions = (Partition(1, 3.0, cut_s), Partition(2, cut_s + 6.0, cut_s))
    launcher = Launcher(spec)
    monitor = launcher.run()
    assert launcher.partitions is not None
    records = launcher.partitions.summary()
    aggregator = records[0]["heard_again_after_heal_s"]["belief_aggregator"]
    agent = records[1]["heard_again_after_heal_s"]["uav0"]
    stamps = records[0]["belief_stamp_ns_at_cut_heal_end"]
    return {
        "recovery_cut_s": cut_s,
        "recovery_belief_after_heal_s": aggregator,
        "recovery_agent_state_after_heal_s": agent,
        "recovery_within_target": all(
            t is not None and t <= RECOVERY_TARGET_S for t in (aggregator, agent)
        ),
        "recovery_belief_advanced_after_heal": bool(stamps and stamps[2] > stamps[1]),
        "recovery_run_decisions": monitor.status.tick if monitor.status else 0,
    }


def _child(backend: str, *args: str) -> dict[str, Any]:
    command = [sys.executable, "-m", "wildfire_bench.network", "--backend", backend]
    env = {**os.environ, "WILDFIRE_ROS_BACKEND": backend}
    done = subprocess.run(
        [*command, *args], env=env, capture_output=True, text=True, check=False, timeout=900
    )
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return {"failed": tail}
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def bench_network(quick: bool = False, smoke: bool = False) -> dict[str, Any]:
    """Both backends: per-hop latency clean and impaired, recovery after a heal."""
    from wildfire_bench.system import _backend_available
    from wildfire_testbed.hosts import namespaces_unavailable

    reason = namespaces_unavailable()
    if reason is not None:
        return {"skipped": reason}
    count = "3" if smoke else "40" if quick else "200"
    result: dict[str, Any] = {"netem": NETEM}
    from wildfire_ros.runtime import BACKEND

    # A smoke run checks the runtime in use only (the tests run it once on each).
    for backend in (BACKEND,) if smoke else BACKENDS:
        if not _backend_available(backend):
            result[f"{backend}_skipped"] = "rclpy does not import"
            continue
        for label, extra in (("clean", []), ("netem", ["--netem", NETEM])):
            figures = _child(backend, "--ping", count, *extra)
            result |= {f"{backend}_{label}_{key}": value for key, value in figures.items()}
        sizes = [*(["--quick"] if quick else []), *(["--smoke"] if smoke else [])]
        figures = _child(backend, "--recovery", *sizes)
        result |= {f"{backend}_{key}": value for key, value in figures.items()}
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description="Network figures of one backend (root).")
    parser.add_argument("--backend", choices=BACKENDS)
    parser.add_argument("--echo", action="store_true", help="be the echo node")
    parser.add_argument("--ping", type=int, metavar="COUNT", help="round trips to measure")
    parser.add_argument("--netem", help="impairment of the ping's hosts")
    parser.add_argument("--recovery", action="store_true", help="partition and heal a run")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--smoke", action="store_true")
    args = parser.parse_args()
    if args.backend is not None:
        os.environ["WILDFIRE_ROS_BACKEND"] = args.backend
    if args.echo:
        echo_main()
        return
    figures = (
        ping_main(args.ping, args.netem) if args.ping else recovery_main(args.quick, args.smoke)
    )
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
