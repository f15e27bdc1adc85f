"""Shared helpers of the ``topic`` and ``bag`` commands: a ROS session and topic QoS.

Not a sub-command (it is not listed in ``COMMAND_MODULES``).
"""

from __future__ import annotations

import contextlib
import time
from typing import TYPE_CHECKING, Any

from wildfire_msgs_py.contract import spec_for

if TYPE_CHECKING:
    from collections.abc import Iterator


@contextlib.contextmanager
def ros_node(name: str) -> Iterator[Any]:
    """Initialize the runtime, yield one node, and always shut down.

    SIGTERM ends the command as Ctrl-C does (one line, no traceback): left to rclpy, it
    invalidates the context under the command's next graph query.
    """
    from wildfire_msgs_py.stop_signals import interrupt_on_stop_signals
    from wildfire_ros.runtime import Node, rclpy

    interrupt_on_stop_signals()
    rclpy.init(args=[])
    node = None
    try:
        node = Node(name)
        yield node
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


def wait_for_topic_type(node: Any, topic: str, timeout: float | None) -> str | None:
    """The type of ``topic`` once it shows up in the graph (None on timeout)."""
    end = None if timeout is None else time.monotonic() + timeout
    while True:
        for name, types in node.get_topic_names_and_types():
            if name == topic and types:
                return types[0]
        if end is not None and time.monotonic() >= end:
            return None
        time.sleep(0.05)


def subscription_qos(node: Any, topic: str, depth: int = 10) -> Any:
    """A QoS matching the topic's publishers (see :func:`wildfire_ros.graph.adapted_qos`)."""
    from wildfire_ros.graph import adapted_qos

    return adapted_qos(node, topic, depth)


def publisher_qos(topic: str, depth: int = 10) -> Any:
    """The contract's QoS for a topic of the system, else reliable/volatile with ``depth``."""
    from wildfire_ros.runtime import QoSProfile, qos_profile

    spec = spec_for(topic)
    return qos_profile(spec.qos) if spec is not None else QoSProfile(depth=depth)


__all__ = ["publisher_qos", "ros_node", "subscription_qos", "wait_for_topic_type"]
