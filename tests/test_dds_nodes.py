"""Nodes on the active backend: executors, QoS, sim time, and pub/sub across OS processes.

These tests use only the :mod:`wildfire_ros.runtime` surface, so where rclpy is
installed they run on rclpy unchanged (``WILDFIRE_ROS_BACKEND=auto``).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from typing import Any

import numpy as np
import pytest

from wildfire_msgs_py import codecs, contract

pytestmark = [pytest.mark.dds, pytest.mark.timeout(60)]


def spin_until(executor: Any, condition: Any, timeout: float = 5.0) -> bool:
    """Spin ``executor`` until ``condition()`` holds or ``timeout`` passes."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        executor.spin_once(timeout_sec=0.05)
    return condition()


def test_several_nodes_on_one_executor(ros_runtime: Any) -> None:
    rt = ros_runtime
    string = rt.get_message("std_msgs/msg/String")
    talker = rt.Node("talker", namespace="/uav0")
    relay = rt.Node("relay", namespace="/uav0")
    listener = rt.Node("listener")
    out = talker.create_publisher(string, "chatter", 10)
    relayed = relay.create_publisher(string, "relayed", 10)
    relay.create_subscription(
        string, "chatter", lambda m: relayed.publish(string(data=m.data.upper())), 10
    )
    heard: list[str] = []
    listener.create_subscription(string, "/uav0/relayed", lambda m: heard.append(m.data), 10)
    count = iter(range(1000))
    talker.create_timer(0.02, lambda: out.publish(string(data=f"msg {next(count)}")))
    executor = rt.SingleThreadedExecutor()
    for node in (talker, relay, listener):
        executor.add_node(node)
    assert spin_until(executor, lambda: len(heard) >= 5)
    assert heard[0].startswith("MSG ") and heard == sorted(heard, key=lambda s: int(s[4:]))
    executor.shutdown()


def test_transient_local_late_joiner_gets_last_grid(ros_runtime: Any) -> None:
    rt = ros_runtime
    grid_type = rt.get_message(contract.FIRE_MAP.type)
    sim = rt.Node("fire_sim")
    publisher = sim.create_publisher(
        grid_type, contract.FIRE_MAP.name, rt.qos_profile(contract.FIRE_MAP.qos)
    )
    grids = [np.random.default_rng(i).random((100, 100)) < 0.2 for i in range(3)]
    for i, grid in enumerate(grids):
        publisher.publish(codecs.fire_grid_to_msg(grid, i))
    late = rt.Node("late_viewer")
    received: list[Any] = []
    late.create_subscription(
        grid_type, contract.FIRE_MAP.name, received.append, rt.qos_profile(contract.FIRE_MAP.qos)
    )
    volatile: list[Any] = []
    late.create_subscription(grid_type, contract.FIRE_MAP.name, volatile.append, 10)
    executor = rt.SingleThreadedExecutor()
    executor.add_node(late)
    assert spin_until(executor, lambda: len(received) >= 1)
    executor.spin_once(timeout_sec=0.3)
    assert len(received) == 1  # depth 1: only the last grid is kept for late joiners
    np.testing.assert_array_equal(codecs.fire_grid_from_msg(received[0]), grids[-1])
    assert volatile == []  # a volatile reader gets no history
    executor.shutdown()


def test_timers_follow_sim_time_from_clock(ros_runtime: Any) -> None:
    rt = ros_runtime
    clock_type = rt.get_message(contract.CLOCK.type)
    sim = rt.Node("clock_source")
    clock_pub = sim.create_publisher(clock_type, "/clock", rt.qos_profile(contract.CLOCK.qos))
    agent = rt.Node("agent", parameter_overrides=[rt.Parameter("use_sim_time", value=True)])
    assert agent.get_parameter("use_sim_time").value is True
    ticks: list[int] = []
    agent.create_timer(0.1, lambda: ticks.append(agent.get_clock().now().nanoseconds))
    executor = rt.SingleThreadedExecutor()
    executor.add_node(sim)
    executor.add_node(agent)
    executor.spin_once(timeout_sec=0.5)
    assert ticks == []  # no /clock yet: sim time stands still however long we wait
    step_ns = 100_000_000
    for step in range(1, 6):
        now = 10_000_000_000 + step * step_ns
        clock_pub.publish(codecs.clock_to_msg(now))
        assert spin_until(executor, lambda now=now: agent.get_clock().now().nanoseconds == now)
        spin_until(executor, lambda step=step: len(ticks) >= step, timeout=1.0)
    assert ticks == [10_000_000_000 + s * step_ns for s in range(1, 6)]
    executor.shutdown()


def test_publish_rejects_wrong_message_type(ros_runtime: Any) -> None:
    rt = ros_runtime
    node = rt.Node("typed")
    publisher = node.create_publisher(rt.get_message("std_msgs/msg/Float64"), "score", 1)
    with pytest.raises(TypeError):
        publisher.publish(rt.get_message("std_msgs/msg/String")(data="x"))


CHILD_PUBLISHER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from wildfire_msgs_py import codecs
    from wildfire_ros.runtime import Node, QoSProfile, get_message, rclpy

    rclpy.init(args=sys.argv)
    node = Node("child_publisher")
    pub = node.create_publisher(get_message("nav_msgs/msg/OccupancyGrid"), "/uav1/visit", 10)
    state = node.create_publisher(get_message("std_msgs/msg/Float64MultiArray"), "/uav1/state", 10)
    end = time.monotonic() + 20
    while pub.get_subscription_count() == 0 and time.monotonic() < end:
        time.sleep(0.02)
    grid = np.arange(10000).reshape(100, 100) % 3 == 0
    for i in range(5):
        pub.publish(codecs.fire_grid_to_msg(grid, i))
        state.publish(codecs.state_to_msg([1.0 / 3.0, 2.0, 3.0, float(i)]))
        time.sleep(0.05)
    time.sleep(0.5)
    rclpy.shutdown()
    """
)


def test_pub_sub_across_processes(ros_runtime: Any, dds_env: dict[str, str]) -> None:
    rt = ros_runtime
    node = rt.Node("parent_subscriber")
    grids: list[Any] = []
    states: list[Any] = []
    node.create_subscription(
        rt.get_message("nav_msgs/msg/OccupancyGrid"), "/uav1/visit", grids.append, 10
    )
    node.create_subscription(
        rt.get_message("std_msgs/msg/Float64MultiArray"), "/uav1/state", states.append, 10
    )
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD_PUBLISHER],
        env=dds_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        executor = rt.SingleThreadedExecutor()
        executor.add_node(node)
        assert spin_until(executor, lambda: len(grids) >= 5 and len(states) >= 5, timeout=30)
    finally:
        _, err = child.communicate(timeout=30)
    assert child.returncode == 0, err
    expected = np.arange(10000).reshape(100, 100) % 3 == 0
    np.testing.assert_array_equal(codecs.fire_grid_from_msg(grids[-1]), expected)
    assert [codecs.time_from_msg(g.header.stamp) for g in grids] == list(range(5))
    assert codecs.state_from_msg(states[0])[0] == 1.0 / 3.0


def test_rclpy_backend_is_used_when_installed(dds_env: dict[str, str]) -> None:
    pytest.importorskip("rclpy", reason="rclpy (ROS 2 Jazzy) is not installed on this machine")
    code = (
        "from wildfire_ros.runtime import BACKEND, get_message; "
        "print(BACKEND, get_message('std_msgs/msg/String').__module__)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        env={**dds_env, "WILDFIRE_ROS_BACKEND": "auto"},
        capture_output=True,
        text=True,
        timeout=30,
        check=True,
    ).stdout.split()
    assert out[0] == "rclpy" and out[1].startswith("std_msgs.msg")


def test_dds_backend_falls_back_to_loopback_config(dds_env: dict[str, str]) -> None:
    env = dict(dds_env)
    env.pop("CYCLONEDDS_URI")
    env["WILDFIRE_ROS_BACKEND"] = "dds"
    code = (
        "import os; from wildfire_ros.runtime import rclpy, BACKEND; rclpy.init(args=[]); "
        "print(BACKEND, os.environ['CYCLONEDDS_URI']); rclpy.shutdown()"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        env=env,
        capture_output=True,
        text=True,
        timeout=30,
        check=True,
    ).stdout
    assert out.startswith("dds ")
    assert '<NetworkInterface address="127.0.0.1"/>' in out
    assert "<AllowMulticast>false</AllowMulticast>" in out


def test_bad_backend_choice_is_reported(dds_env: dict[str, str]) -> None:
    env = dict(dds_env, WILDFIRE_ROS_BACKEND="zenoh")
    result = subprocess.run(
        [sys.executable, "-c", "import wildfire_ros.runtime"],
        env=env,
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert result.returncode != 0
    assert "expected one of auto, rclpy, dds" in result.stderr
