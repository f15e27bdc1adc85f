"""Cyclone DDS settings of the DDS backend: the domain id, checked as ROS 2 does.

The loopback-only network configuration lives in :mod:`wildfire_ros.network_defaults`,
shared with the rclpy backend.
"""

from __future__ import annotations

import os

from wildfire_msgs_py.errors import BackendError


def ros_domain_id() -> int:
    """``ROS_DOMAIN_ID`` (default 0), checked to lie in 0..232 like ROS 2 requires."""
    text = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    try:
        domain = int(text)
    except ValueError:
        raise BackendError(f"ROS_DOMAIN_ID={text!r}: expected a whole number 0..232") from None
    if not 0 <= domain <= 232:
        raise BackendError(f"ROS_DOMAIN_ID={text!r}: expected a whole number 0..232")
    return domain


__all__ = ["ros_domain_id"]
