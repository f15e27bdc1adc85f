"""`wildfire bench` as the README shows it: every suite, no ``--only``, on the runtime of the
test pass (``scripts/test.sh`` runs this once on real rclpy and once on the Cyclone layer).

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


def test_bench_runs_every_suite_and_reports_its_figures(dds_env: dict[str, str]) -> None:
    from wildfire_cli.bench import SUITES
    from wildfire_testbed.hosts import namespaces_unavailable

    result = subprocess.run(
        [WILDFIRE, "bench", "--quick", "--smoke", "--json"],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=580,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert "Traceback" not in result.stderr
    figures = json.loads(result.stdout)
    for suite in SUITES:
        assert suite in figures, suite
        assert not any(key.endswith("failed") for key in figures[suite]), figures[suite]
        assert figures[suite]["bench_seconds"] > 0
    if namespaces_unavailable() is None:
        assert "skipped" not in figures["network"], figures["network"]
    assert figures["fire"]["fire_env_steps_per_s"] > 0
    assert figures["env"]["decisions_per_s"] > 0
    assert figures["rh"]["plans_identical"] and figures["rh"]["plan_speedup"] > 0
    assert figures["inference"]["obs_inference_ms"] > 0
    assert figures["dds"]["grid_messages_received"] > 0
    # A smoke run flies the system on the pass's own runtime.
    backend = os.environ["WILDFIRE_ROS_BACKEND"]
    assert figures["system"][f"{backend}_lockstep_speedup"] > 0


def test_map_size_sets_the_field_world_of_the_fire_and_env_suites() -> None:
    from wildfire_bench.core import bench_env, bench_fire
    from wildfire_sim.grid import MapGeometry

    fire = bench_fire(steps=2, batch_sizes=(4,), field_map=MapGeometry(200, 300))
    assert fire["field_map"] == "200,300" and fire["step_ms_map_field"] > 0
    assert fire["step_ms_map_ratio"] == fire["step_ms_map_field"] / fire["step_ms_map_100"]
    env = bench_env(decisions=3, batch_sizes=(8,), field_map=MapGeometry(200, 300))
    assert env["field_map"] == "200,300" and env["decisions_per_s_field"] > 0
    # A 200 x 300 field holds less than the default 1000 x 1000 one, more than the paper's.
    assert env["bytes_per_env_disc"] < env["bytes_per_env_field"] < 2e6
    result = subprocess.run(
        [WILDFIRE, "bench", "--only", "fire", "--map-size", "3000,100"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2 and "--map-size" in result.stderr
    assert "Traceback" not in result.stderr
