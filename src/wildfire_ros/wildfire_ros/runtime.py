"""One import surface for node code on both backends.

``WILDFIRE_ROS_BACKEND`` selects the backend (:mod:`wildfire_msgs_py.messages` reads it once,
so the codecs build the classes this runtime publishes):

* ``rclpy`` — the real rclpy of ROS 2 Jazzy (the pip wheels ``ros-jazzy-rclpy`` or a sourced
  install), real rosidl message classes;
* ``dds`` — :mod:`wildfire_ros.dds`, our rclpy-compatible layer over Cyclone DDS;
* ``auto`` (default) — rclpy when it imports, else dds.

Node code imports everything from here and runs unchanged on both::

    from wildfire_ros.runtime import (
        ExternalShutdownException, Node, QoSProfile, SingleThreadedExecutor, get_message, rclpy,
    )
    OccupancyGrid = get_message("nav_msgs/msg/OccupancyGrid")

``qos_profile(spec)`` turns a contract QoS into the backend's profile, ``make_executor()``
gives the executor nodes spin on and ``spin(executor)`` spins it until shutdown.
``serialize_message``/``deserialize_message`` convert to and from CDR bytes (as
``rclpy.serialization``), ``PARAMETER_ERRORS`` lists the exceptions a bad parameter raises and
``INIT_ERRORS`` those of a command line ``rclpy.init`` refuses.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

from wildfire_msgs_py.contract import QosSpec
from wildfire_msgs_py.errors import BackendError, ParameterError
from wildfire_msgs_py.messages import BACKEND, get_message
from wildfire_ros.network_defaults import apply_local_network_defaults

# Before rclpy or Cyclone creates anything: loopback-only DDS unless the user chose otherwise.
apply_local_network_defaults()

_EXECUTORS = ("events", "single")


def _choose_executor() -> str:
    choice = os.environ.get("WILDFIRE_ROS_EXECUTOR", "events").strip().lower() or "events"
    if choice not in _EXECUTORS:
        raise BackendError(
            f"WILDFIRE_ROS_EXECUTOR={choice!r}: expected one of {', '.join(_EXECUTORS)}"
        )
    return choice


#: rclpy's executor: ``"events"`` (``rclpy.experimental.EventsExecutor``) or ``"single"``.
EXECUTOR = _choose_executor()

# mypy checks node code against the Cyclone layer: it is always installed, and what it offers
# is the surface both backends share (the rclpy branch is its reference, typed by rclpy).
if BACKEND == "rclpy" and not TYPE_CHECKING:
    import rclpy
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
    from rclpy._rclpy_pybind11 import RCLError
    from rclpy.duration import Duration
    from rclpy.exceptions import (
        InvalidParameterTypeException,
        InvalidParameterValueException,
        ParameterAlreadyDeclaredException,
        ParameterNotDeclaredException,
    )
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.serialization import deserialize_message, serialize_message
    from rclpy.time import Time
    from rclpy.utilities import remove_ros_args

    def make_executor() -> Any:
        """The executor a node spins on: rclpy's ``EventsExecutor`` unless
        ``WILDFIRE_ROS_EXECUTOR=single``.

        The events executor dispatches in C++. The ``SingleThreadedExecutor`` rebuilds its
        wait set in Python on every wake, over every subscription, timer, service and QoS event
        of the node: a 3-aircraft lockstep run with random actions went from 3.4x to 8.4x real
        time on this 2-core machine with the events executor. An rclpy without one (older
        releases) gets the single-threaded executor.
        """
        if EXECUTOR == "events":
            try:
                from rclpy.experimental import EventsExecutor
            except ImportError:
                pass
            else:
                return EventsExecutor()
        return SingleThreadedExecutor()

    def rmw_implementation() -> str:
        """The middleware under rclpy, e.g. ``rmw_fastrtps_cpp`` (as ``ros2 doctor`` names it)."""
        from rclpy.utilities import get_rmw_implementation_identifier

        return str(get_rmw_implementation_identifier())

    # rcl's refusal of a command line (e.g. a malformed --ros-args value) at rclpy.init.
    INIT_ERRORS: tuple[type[BaseException], ...] = (RCLError,)
    PARAMETER_ERRORS: tuple[type[BaseException], ...] = (
        ParameterError,
        InvalidParameterTypeException,
        InvalidParameterValueException,
        ParameterAlreadyDeclaredException,
        ParameterNotDeclaredException,
    )

else:
    from wildfire_msgs_py.types import deserialize as _deserialize
    from wildfire_msgs_py.types import serialize as serialize_message
    from wildfire_ros import dds as rclpy
    from wildfire_ros.dds.clock import Duration, Time
    from wildfire_ros.dds.context import ExternalShutdownException
    from wildfire_ros.dds.executor import SingleThreadedExecutor
    from wildfire_ros.dds.node import Node
    from wildfire_ros.dds.parameters import Parameter
    from wildfire_ros.dds.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )

    remove_ros_args = rclpy.remove_ros_args

    def make_executor() -> Any:
        """Our layer's single-threaded executor (it waits on DDS conditions natively)."""
        return SingleThreadedExecutor()

    def rmw_implementation() -> str:
        """Our Cyclone DDS layer speaks the wire format of rmw_cyclonedds_cpp."""
        return "wildfire_cyclonedds"

    INIT_ERRORS: tuple[type[BaseException], ...] = ()
    PARAMETER_ERRORS: tuple[type[BaseException], ...] = (ParameterError,)
    ParameterDescriptor = get_message("rcl_interfaces/msg/ParameterDescriptor")
    FloatingPointRange = get_message("rcl_interfaces/msg/FloatingPointRange")
    IntegerRange = get_message("rcl_interfaces/msg/IntegerRange")

    def deserialize_message(serialized_message: bytes, message_type: Any) -> Any:
        """CDR bytes to a message (``rclpy.serialization.deserialize_message``)."""
        return _deserialize(serialized_message, message_type)


def qos_profile(spec: QosSpec) -> Any:
    """The ``QoSProfile`` of a contract QoS on the backend in use (always KEEP_LAST)."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=spec.depth,
        reliability=ReliabilityPolicy.RELIABLE if spec.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=(
            DurabilityPolicy.TRANSIENT_LOCAL if spec.transient_local else DurabilityPolicy.VOLATILE
        ),
    )


def spin(executor: Any, period_s: float = 0.1) -> None:
    """Spin ``executor`` until the context shuts down (``rclpy.ok()`` turns false).

    Through ``spin_once``: rclpy 7.1.6's ``EventsExecutor.spin()`` never ran our nodes'
    timers, and a bounded wait returns to Python often enough for SIGINT to be handled.
    """
    while rclpy.ok():
        executor.spin_once(timeout_sec=period_s)


__all__ = [
    "BACKEND",
    "EXECUTOR",
    "INIT_ERRORS",
    "PARAMETER_ERRORS",
    "DurabilityPolicy",
    "Duration",
    "ExternalShutdownException",
    "FloatingPointRange",
    "HistoryPolicy",
    "IntegerRange",
    "Node",
    "Parameter",
    "ParameterDescriptor",
    "QoSProfile",
    "ReliabilityPolicy",
    "SingleThreadedExecutor",
    "Time",
    "deserialize_message",
    "get_message",
    "make_executor",
    "qos_profile",
    "rclpy",
    "remove_ros_args",
    "rmw_implementation",
    "serialize_message",
    "spin",
]
