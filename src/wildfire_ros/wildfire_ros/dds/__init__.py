"""DDS backend: an rclpy-compatible layer over Eclipse Cyclone DDS speaking the ROS 2 wire format.

This module doubles as the ``rclpy`` stand-in that :mod:`wildfire_ros.runtime` exports:
``init``, ``shutdown``, ``try_shutdown``, ``ok``, ``spin``, ``spin_once`` and
``spin_until_future_complete`` behave like their rclpy namesakes on a process-wide context.
Wire format as rmw_cyclonedds_cpp: DDS topic ``rt/<name>``, type ``<pkg>::msg::dds_::<Type>_``,
XCDR1 CDR; QoS mapped like rmw_cyclonedds (see :mod:`wildfire_ros.dds.qos`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from wildfire_ros.dds.arguments import remove_ros_args
from wildfire_ros.dds.context import Context, ExternalShutdownException, default_context
from wildfire_ros.dds.executor import SingleThreadedExecutor

if TYPE_CHECKING:
    from collections.abc import Sequence

    from wildfire_ros.dds.node import Node

_global_executor: SingleThreadedExecutor | None = None


def init(
    *,
    args: Sequence[str] | None = None,
    context: Context | None = None,
    domain_id: int | None = None,
    **_ignored: Any,
) -> None:
    """Initialize ROS: parse ``--ros-args`` in ``args`` and create the DDS participant."""
    (context or default_context).init(args, domain_id=domain_id)


def ok(*, context: Context | None = None) -> bool:
    """True between ``init`` and ``shutdown``."""
    return (context or default_context).ok()


def shutdown(*, context: Context | None = None, **_ignored: Any) -> None:
    """Shut down; raises RuntimeError when not initialized (as rclpy)."""
    global _global_executor
    if _global_executor is not None:
        _global_executor.shutdown()
        _global_executor = None
    (context or default_context).shutdown()


def try_shutdown(*, context: Context | None = None, **_ignored: Any) -> None:
    """Shut down unless already shut down."""
    if (context or default_context).ok():
        shutdown(context=context)


def get_global_executor() -> SingleThreadedExecutor:
    """The executor ``spin``/``spin_once`` use when none is given."""
    global _global_executor
    if _global_executor is None:
        _global_executor = SingleThreadedExecutor()
    return _global_executor


def spin(node: Node, executor: SingleThreadedExecutor | None = None) -> None:
    """Run the node's callbacks until shutdown."""
    executor = executor or get_global_executor()
    try:
        executor.add_node(node)
        while executor.context.ok():
            executor.spin_once()
    finally:
        executor.remove_node(node)


def spin_once(
    node: Node, *, executor: SingleThreadedExecutor | None = None, timeout_sec: float | None = None
) -> None:
    """Run at most one callback of the node."""
    executor = executor or get_global_executor()
    try:
        executor.add_node(node)
        executor.spin_once(timeout_sec=timeout_sec)
    finally:
        executor.remove_node(node)


def spin_until_future_complete(
    node: Node,
    future: Any,
    executor: SingleThreadedExecutor | None = None,
    timeout_sec: float | None = None,
) -> None:
    """Spin the node until ``future.done()`` or the timeout."""
    executor = executor or get_global_executor()
    try:
        executor.add_node(node)
        executor.spin_until_future_complete(future, timeout_sec)
    finally:
        executor.remove_node(node)


__all__ = [
    "ExternalShutdownException",
    "SingleThreadedExecutor",
    "get_global_executor",
    "init",
    "ok",
    "remove_ros_args",
    "shutdown",
    "spin",
    "spin_once",
    "spin_until_future_complete",
    "try_shutdown",
]
