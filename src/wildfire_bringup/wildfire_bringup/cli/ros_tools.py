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
    """Initialize the runtime, yield one node, and always shut down."""
    from wildfire_msgs_py.runtime import Node, rclpy

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
    """A QoS that matches the topic's publishers: the contract's, else adapted to the graph.

    Like ``ros2 topic echo``: reliable only if every publisher is reliable, transient-local
    only if every publisher is (so a late ``echo`` still receives a latched map).
    """
    from wildfire_msgs_py.runtime import (
        BACKEND,
        DurabilityPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )

    reliable, latched = True, False
    spec = spec_for(topic)
    if spec is not None:
        reliable, latched = spec.qos.reliable, spec.qos.transient_local
    elif BACKEND == "dds":
        publishers = [e for e in node.context.graph().endpoints(topic) if e.kind == "publication"]
        if publishers:
            reliable = all(e.qos["reliability"] == "RELIABLE" for e in publishers)
            latched = all(e.qos["durability"] == "TRANSIENT_LOCAL" for e in publishers)
    else:
        infos = node.get_publishers_info_by_topic(topic)
        if infos:
            reliable = all(i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos)
            latched = all(
                i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos
            )
    return QoSProfile(
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def publisher_qos(topic: str, depth: int = 10) -> Any:
    """The contract's QoS for a topic of the system, else reliable/volatile with ``depth``."""
    from wildfire_msgs_py.runtime import QoSProfile

    spec = spec_for(topic)
    return spec.qos.profile() if spec is not None else QoSProfile(depth=depth)


__all__ = ["publisher_qos", "ros_node", "subscription_qos", "wait_for_topic_type"]
