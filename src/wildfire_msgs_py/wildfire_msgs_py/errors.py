"""Errors of the ROS 2 communication layer.

Every class derives from :class:`WildfireRosError`, which the ``wildfire`` CLI reports as one
line (``wildfire topic: error: ...``) with exit status 2. Messages name the offending input and
say what was expected.
"""

from __future__ import annotations


class WildfireRosError(Exception):
    """Base class: a user-facing problem with topics, messages, parameters or bags."""


class UnknownMessageTypeError(WildfireRosError):
    """A message type name that is malformed or not in the ROS 2 Jazzy type store."""


class MessageFieldError(WildfireRosError):
    """Field values (e.g. YAML given to ``topic pub``) that do not fit the message type."""


class ParameterError(WildfireRosError):
    """A bad ``--ros-args`` option, parameter value, parameters file or parameter access."""


class TopicNameError(WildfireRosError):
    """A topic or namespace that is not a valid ROS 2 name."""


class BagError(WildfireRosError):
    """A missing, unreadable or corrupt rosbag2 directory, or a recording that cannot be written."""


class BackendError(WildfireRosError):
    """The requested backend cannot be used (``WILDFIRE_ROS_BACKEND=rclpy`` without rclpy)."""


class ShutdownError(WildfireRosError):
    """The runtime was used before ``rclpy.init()`` or after ``rclpy.shutdown()``."""


__all__ = [
    "BackendError",
    "BagError",
    "MessageFieldError",
    "ParameterError",
    "ShutdownError",
    "TopicNameError",
    "UnknownMessageTypeError",
    "WildfireRosError",
]
