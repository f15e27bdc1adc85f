"""`wildfire bench` as docs/cli.md shows it: every suite, no ``--only``, on the runtime of the
test pass (``scripts/test.sh`` runs this once on real rclpy and once on the Cyclone layer;
the second time only the suites whose code depends on the backend: dds, system, network).

``--smoke`` runs each suite once at its smallest size: the figures mean nothing, but every
code path of every suite runs, as it did when the dds suite crashed on rclpy's messages."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

# Not in the "system" group (conftest.py): its figures are never asserted, so it may share the
# machine with a system test, and on its own worker it costs the suite no wall time.
pytestmark = [
    pytest.mark.dds,
    pytest.mark.slow,
    pytest.mark.timeout(600),
    pytest.mark.xdist_group("bench"),
]
WILDFIRE = str(Path(sys.executable).parent / "wildfire")


def _second_pass() -> bool:
    """The Cyclone pass after the rclpy one: the suites that touch no ROS ran there."""
    import importlib.util

    return (
        os.environ["WILDFIRE_ROS_BACKEND"] == "dds"
        and importlib.util.find_spec("rclpy") is not None
    )


ROS_SUITES = ("dds", "system", "network")
"""The suites whose code depends on the runtime backend."""


def test_bench_runs_every_suite_and_reports_its_figures(dds_env: dict[str, str]) -> None:
    from wildfire_cli.bench import SUITES
    from wildfire_testbed.hosts import namespaces_unavailable

    # Asked for by name, the network suite needs root; in a full bench it says it skipped.
    ros_suites = [s for s in ROS_SUITES if s != "network" or namespaces_unavailable() is None]
    suites = ros_suites if _second_pass() else list(SUITES)
    only = ["--only", *suites] if _second_pass() else []
    result = subprocess.run(
        [WILDFIRE, "bench", "--quick", "--smoke", "--json", *only],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=580,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert "Traceback" not in result.stderr
    figures = json.loads(result.stdout)
    for suite in suites:
        assert suite in figures, suite
        assert not any(key.endswith("failed") for key in figures[suite]), figures[suite]
        assert figures[suite]["bench_seconds"] > 0
    if namespaces_unavailable() is None:
        assert "skipped" not in figures["network"], figures["network"]
    if not _second_pass():
        assert figures["fire"]["fire_env_steps_per_s"] > 0
        assert figures["env"]["decisions_per_s"] > 0
        assert figures["rh"]["plans_identical"] and figures["rh"]["plan_speedup"] > 0
        assert figures["inference"]["obs_inference_ms"] > 0
    assert figures["dds"]["grid_messages_received"] > 0
    # A smoke run flies the system on the pass's own runtime.
    backend = os.environ["WILDFIRE_ROS_BACKEND"]
    assert figures["system"][f"{backend}_lockstep_speedup"] > 0
