"""The message classes of the ROS 2 runtime in use, and the choice of that runtime.

``WILDFIRE_ROS_BACKEND`` selects the backend once, when this module is first imported:

* ``rclpy`` — the real rclpy of ROS 2 Jazzy (the pip wheels ``ros-jazzy-rclpy`` or a sourced
  install): messages are rosidl's generated classes;
* ``dds`` — the Cyclone DDS layer of :mod:`wildfire_ros`: messages are the classes of
  :mod:`wildfire_msgs_py.types`;
* ``auto`` (default) — rclpy when it imports, else dds.

The codecs build messages through :func:`get_message`, and :mod:`wildfire_ros.runtime` runs
the same backend, so a message made here is one the runtime publishes.
"""

from __future__ import annotations

import importlib
import os
from typing import Any

from wildfire_msgs_py.errors import BackendError, UnknownMessageTypeError

_CHOICES = ("auto", "rclpy", "dds")


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


#: The backend in use: ``"rclpy"`` or ``"dds"``.
BACKEND = _choose_backend()


def get_message(type_name: str) -> Any:
    """The message class of ``pkg/msg/Type`` on the backend in use.

    rclpy's are imported as ``<pkg>.msg`` directly: the pip wheels of ROS 2 Jazzy have no
    rosidl_runtime_py.
    """
    from wildfire_msgs_py import types

    if BACKEND == "dds":
        return types.get_message(type_name)
    name = types.normalize_type_name(type_name)
    package, _, message = name.partition("/msg/")
    try:
        return getattr(importlib.import_module(f"{package}.msg"), message)
    except (AttributeError, ImportError, ValueError):
        raise UnknownMessageTypeError(
            f"message type {type_name!r} is not installed in this ROS 2 environment"
        ) from None


__all__ = ["BACKEND", "get_message"]
