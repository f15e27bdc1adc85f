"""Hostile input, system side: a separate participant floods every topic with malformed,
out-of-range and replayed messages while ``wildfire run`` flies; no node dies, the lockstep
episode still equals ``wildfire eval`` and every kind of bad message is counted."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from wildfire_belief.radio import CommModel
from wildfire_learning.env import EnvConfig
from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy

pytestmark = [pytest.mark.dds, pytest.mark.slow, pytest.mark.timeout(300)]
WILDFIRE = str(Path(sys.executable).parent / "wildfire")
BELIEF_POLICY = Path(__file__).resolve().parents[1] / "models" / "belief_policy.pt"
RATE_HZ = 200


@pytest.fixture
def fuzzer(dds_env: dict[str, str]) -> Iterator[subprocess.Popen[str]]:
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "wildfire_testbed.wire_fuzzer",
            "--aircraft",
            "2",
            "--rate",
            str(RATE_HZ),
            "--duration",
            "280",
        ],
        env=dds_env,
        stderr=subprocess.PIPE,
        text=True,
    )
    yield process
    process.terminate()
    _, stderr = process.communicate(timeout=30)
    assert "sent" in stderr, stderr  # the fuzzer itself ran to the end


def run(args: list[str], env: dict[str, str]) -> dict[str, object]:
    result = subprocess.run(
        [WILDFIRE, "run", "--aircraft", "2", "--json", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=270,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    summary: dict[str, object] = json.loads(result.stdout)
    return summary


def drops(summary: dict[str, object], node: str) -> dict[str, float]:
    counts = summary["dropped_inputs"]
    assert isinstance(counts, dict)
    found: dict[str, float] = counts[node]
    return found


def test_lockstep_under_a_flood_equals_evaluate(
    fuzzer: subprocess.Popen[str], dds_env: dict[str, str]
) -> None:
    seed, duration = 3, 15.0
    summary = run(
        [
            "--policy",
            str(BELIEF_POLICY),
            "--seed",
            str(seed),
            "--duration",
            str(duration),
            "--fast",
            "--wind",
            "0.2,0.1",
        ],
        dds_env,
    )
    config = EnvConfig(n_aircraft=2, shapes=("circular",), wind=(0.2, 0.1), max_duration_s=duration)
    reference = evaluate(make_vec_policy(str(BELIEF_POLICY)), config, [seed]).episodes[0]
    assert summary["score"] == reference.score
    assert summary["decisions"] == reference.decisions
    assert fuzzer.poll() is None, "the fuzzer stopped before the run ended"

    # Each kind of bad input reached a node that refused and counted it.
    expected = {
        "uav0/agent": [
            "/wildfire/fire_map malformed",
            "/wildfire/fire_map out of range",
            "/wildfire/fire_map wrong frame",
            "/wildfire/fire_map future",
            "/uav1/state_stamped malformed",
            "/uav1/state_stamped out of range",
            "/uav1/state_stamped future",
            "/uav1/state_stamped stale",
            "/wildfire/episode malformed",
            "/wildfire/episode wrong frame",
            "/wildfire/belief out of range",
            "/wildfire/belief_age_exact out of range",
            "/wildfire/score out of range",
        ],
        "belief_aggregator": [
            "/uav0/visit malformed",
            "/uav0/visit out of range",
            "/uav0/visit future",
            "/wildfire/belief_snapshot malformed",
            "/wildfire/belief_snapshot out of range",
        ],
        "fire_simulator": ["/wildfire/ack future", "/wildfire/ack wrong frame"],
        "wildfire_run": ["/wildfire/fuel_map malformed", "/uav0/state_stamped duplicate"],
    }
    for node, keys in expected.items():
        counted = drops(summary, node)
        missing = [key for key in keys if counted.get(key, 0) < 1]
        assert not missing, f"{node} counted no {missing}: {counted}"
        assert counted["dropped"] >= sum(counted[key] for key in keys)


def test_limited_links_under_a_flood_equal_evaluate(
    fuzzer: subprocess.Popen[str], dds_env: dict[str, str]
) -> None:
    """Radio messages that lie (another aircraft's index, NaN poses, windows off the pose,
    truncated bytes, catch-up replies that do not inflate, future ticks) are dropped and
    counted, and never change a decision."""
    seed, duration, comm = 4, 12.0, "range=300,loss=0.2"
    summary = run(
        ["--policy", "rh", "--seed", str(seed), "--duration", str(duration), "--fast",
         "--comm", comm],
        dds_env,
    )  # fmt: skip
    config = EnvConfig(
        n_aircraft=2, shapes=("circular",), max_duration_s=duration, comm=CommModel.parse(comm)
    )
    reference = evaluate(make_vec_policy("rh"), config, [seed]).episodes[0]
    assert summary["score"] == reference.score
    counted = drops(summary, "uav0/agent")
    for reason in ("impersonation", "malformed", "out of range", "future"):
        assert counted.get(f"/uav1/radio {reason}", 0) >= 1, counted


def test_realtime_nodes_survive_a_flood(
    fuzzer: subprocess.Popen[str], dds_env: dict[str, str]
) -> None:
    summary = run(["--realtime", "--duration", "8", "--policy", "rh"], dds_env)
    assert summary["end"] == "truncated" and summary["decisions"] == 80
    for node in ("uav0/agent", "uav1/agent", "belief_aggregator", "wildfire_run"):
        assert drops(summary, node)["dropped"] > 0, node
