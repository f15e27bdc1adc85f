"""The ground on the wire: the fire simulator sends the run's ground file, the others wait.

Thin ROS glue around :mod:`wildfire_sim.ground_file`, called by the nodes right after they
declare their parameters: :func:`publish_ground` (the fire simulator, with ``ground_file``)
and :func:`await_ground` (every other node, with ``ground_sha256`` alone). Both do nothing
without rasters, so a run on the paper's map or with seeded ignitions has no such topic.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from wildfire_msgs_py import contract
from wildfire_msgs_py.errors import ParameterError
from wildfire_msgs_py.system_codecs import ground_from_msg, ground_to_msg
from wildfire_ros.node_support import contract_publisher, contract_subscription
from wildfire_sim.ground_file import accept_ground, ground_bytes, has_received

GROUND_WAIT_S = 60.0
"""Longest wait for the ground: DDS discovery on a loaded machine (or across hosts)."""


def publish_ground(node: Any, p: Mapping[str, Any]) -> Any:
    """The fire simulator: send its ground file, latched (the publisher, to keep; None
    without a ground file)."""
    if not p["ground_file"]:
        return None
    publisher = contract_publisher(node, contract.GROUND)
    publisher.publish(ground_to_msg(ground_bytes(p["ground_file"], p["ground_sha256"])))
    return publisher


def await_ground(node: Any, p: Mapping[str, Any], timeout_s: float = GROUND_WAIT_S) -> None:
    """Every other node: spin until the ground whose digest is ``ground_sha256`` arrives
    (another ground is ignored and logged); ParameterError in one line if none does."""
    from wildfire_ros.runtime import rclpy

    sha256 = p["ground_sha256"]
    if p["ground_file"] or not sha256 or has_received(sha256):
        return
    logger = node.get_logger()

    def on_ground(msg: Any) -> None:
        if not accept_ground(ground_from_msg(msg), sha256):
            logger.warning(f"{contract.GROUND.name}: ignored a ground of another run")

    subscription = contract_subscription(node, contract.GROUND, on_ground)
    deadline = time.monotonic() + timeout_s
    try:
        while not has_received(sha256) and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        node.destroy_subscription(subscription)
    if not has_received(sha256):
        raise ParameterError(
            f"parameter ground_sha256 {sha256[:12]}...: no such ground on "
            f"{contract.GROUND.name} within {timeout_s:.0f} s (is the fire simulator running "
            "with its ground_file?)"
        )


__all__ = ["GROUND_WAIT_S", "await_ground", "publish_ground"]
