"""Tests parametrized over the two runtime backends: when each case runs.

``scripts/test.sh`` runs the suite on real rclpy, then the ROS-facing tests (marker ``dds``)
again on the Cyclone DDS layer. A ``dds``-marked test that starts its own processes on a given
backend would otherwise fly its Cyclone case in both passes.
"""

from __future__ import annotations

import os

import pytest

BACKENDS = ["rclpy", "dds"]


def require_backend(backend: str, own_pass_only: bool = False) -> None:
    """Skip unless ``backend`` imports here (and, with ``own_pass_only``, unless the running
    pass is ``backend``'s: the case then runs once per ``scripts/test.sh``)."""
    if own_pass_only and backend != os.environ.get("WILDFIRE_ROS_BACKEND"):
        pytest.skip(f"the {backend} case runs in the {backend} pass of scripts/test.sh")
    module = "rclpy" if backend == "rclpy" else "cyclonedds"
    try:
        __import__(module)
    except ImportError as error:
        pytest.skip(f"backend {backend}: {module} does not import ({error})")
