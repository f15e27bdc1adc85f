"""One import surface for node code on both backends.

``WILDFIRE_ROS_BACKEND`` selects the backend when this module is first imported:

* ``rclpy`` — the real rclpy of ROS 2 Jazzy (the pip wheels ``ros-jazzy-rclpy`` or a sourced
  install), real rosidl message classes;
* ``dds`` — :mod:`wildfire_msgs_py.dds`, our rclpy-compatible layer over Cyclone DDS;
* ``auto`` (default) — rclpy when it imports, else dds.

Node code imports everything from here and runs unchanged on both::

    from wildfire_msgs_py.runtime import (
        ExternalShutdownException, Node, QoSProfile, SingleThreadedExecutor, get_message, rclpy,
    )
    OccupancyGrid = get_message("nav_msgs/msg/OccupancyGrid")

``make_executor()`` gives the executor nodes spin on and ``spin(executor)`` spins it until
shutdown. ``serialize_message``/``deserialize_message`` convert to and from CDR bytes (as
``rclpy.serialization``), ``PARAMETER_ERRORS`` lists the exceptions a bad parameter raises and
``INIT_ERRORS`` those of a command line ``rclpy.init`` refuses.
"""

from __future__ import annotations

import importlib
import os
from typing import TYPE_CHECKING, Any

from wildfire_msgs_py.errors import BackendError, ParameterError, UnknownMessageTypeError
from wildfire_msgs_py.network import apply_local_network_defaults

# Before rclpy or Cyclone creates anything: loopback-only DDS unless the user chose otherwise.
apply_local_network_defaults()

_CHOICES = ("auto", "rclpy", "dds")
_EXECUTORS = ("events", "single")


def _choose_backend() -> str:
    choice = os.environ.get("WILDFIRE_ROS_BACKEND", "auto").strip().lower() or "auto"
    if choice not in _CHOICES:
        raise BackendError(
            f"WILDFIRE_ROS_BACKEND={choice!r}: expected one of {', '.join(_CHOICES)}"
        )
    if choice == "dds":
        return "dds"
    try:
        importlib.import_module("rclpy")
    except ImportError:
        if choice == "rclpy":
            raise BackendError(
                "WILDFIRE_ROS_BACKEND=rclpy but rclpy does not import: source a ROS 2 Jazzy "
                "install (setup.bash) or use WILDFIRE_ROS_BACKEND=dds"
            ) from None
        return "dds"
    return "rclpy"


def _choose_executor() -> str:
    choice = os.environ.get("WILDFIRE_ROS_EXECUTOR", "events").strip().lower() or "events"
    if choice not in _EXECUTORS:
        raise BackendError(
            f"WILDFIRE_ROS_EXECUTOR={choice!r}: expected one of {', '.join(_EXECUTORS)}"
        )
    return choice


#: The backend in use: ``"rclpy"`` or ``"dds"``.
BACKEND = _choose_backend()
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
        of the node: a 3-aircraft lockstep run with a random policy went from 3.4x to 6.1x real
        time on this 2-core machine with the events executor. Older rclpy (before 7.1) has
        none, and gets the single-threaded one.
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

    def get_message(type_name: str) -> Any:
        """The rosidl message class of ``pkg/msg/Type``.

        Imported as ``<pkg>.msg`` directly: the pip wheels of ROS 2 Jazzy have no
        rosidl_runtime_py.
        """
        from wildfire_msgs_py.dds.types import normalize_type_name

        name = normalize_type_name(type_name)
        package, _, message = name.partition("/msg/")
        try:
            return getattr(importlib.import_module(f"{package}.msg"), message)
        except (AttributeError, ImportError, ValueError):
            raise UnknownMessageTypeError(
                f"message type {type_name!r} is not installed in this ROS 2 environment"
            ) from None

else:
    from wildfire_msgs_py import dds as rclpy
    from wildfire_msgs_py.dds.clock import Duration, Time
    from wildfire_msgs_py.dds.context import ExternalShutdownException
    from wildfire_msgs_py.dds.executor import SingleThreadedExecutor
    from wildfire_msgs_py.dds.node import Node
    from wildfire_msgs_py.dds.parameters import Parameter
    from wildfire_msgs_py.dds.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )
    from wildfire_msgs_py.dds.types import deserialize as _deserialize
    from wildfire_msgs_py.dds.types import get_message
    from wildfire_msgs_py.dds.types import serialize as serialize_message

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
    "rclpy",
    "remove_ros_args",
    "rmw_implementation",
    "serialize_message",
    "spin",
]
