"""Network faults on virtual hosts: ``wildfire run --hosts K --netem SPEC --partition H:S:D``.

* Without namespaces: the fault options parse what ``tc-netem`` writes, refuse anything else,
  and bad input on the command line is one line and exit status 2; ``wildfire bench --only
  network`` without root says so in one line.
* On each backend, a real-time run on 4 hosts with ``delay 20ms 10ms loss 2%`` on every link and
  the aggregator's host cut off for 6 s finishes: every decision taken, frames were really lost,
  the cut is reported (host, times, the unreachable aggregator) instead of a dead node, the
  monitor hears the aggregator again within 3 s of the heal, and the belief keeps advancing
  after it (the monitor refuses older stamps, so the one it holds only grows).
* On each backend, a lockstep run whose agent host is cut off for 6 s resumes after the heal
  (reliable QoS retransmits what the cut lost) and still flies exactly what ``wildfire eval``
  flies.

Each system test sets ``WILDFIRE_ROS_BACKEND`` itself, as ``tests/test_multihost.py`` does.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from backend_cases import BACKENDS, require_backend
from wildfire_testbed import hosts
from wildfire_testbed.netfaults import (
    FaultSpecError,
    NetemSpec,
    Partition,
    check_partitions,
)

WILDFIRE = str(Path(sys.executable).parent / "wildfire")
RUN_TIMEOUT_S = 240.0
RECOVERY_TARGET_S = 3.0

_UNAVAILABLE = hosts.namespaces_unavailable()
needs_namespaces = pytest.mark.skipif(_UNAVAILABLE is not None, reason=str(_UNAVAILABLE))


def _run(args: list[str], backend: str) -> tuple[dict[str, object], str]:
    env = {**os.environ, "WILDFIRE_ROS_BACKEND": backend, "PYTHONUNBUFFERED": "1"}
    result = subprocess.run(
        [WILDFIRE, "run", "--json", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summary: dict[str, object] = json.loads(result.stdout)
    return summary, result.stderr


# --- no namespace needed -----------------------------------------------------------------------


def test_netem_spec_parses_the_tc_subset() -> None:
    spec = NetemSpec.parse("delay 20ms 10ms loss 2%")
    assert spec == NetemSpec(20.0, 10.0, 2.0)
    assert spec.tc_arguments() == ["delay", "20ms", "10ms", "loss", "2%"]
    assert NetemSpec.parse("loss 0.5%") == NetemSpec(loss_percent=0.5)
    assert NetemSpec.parse("delay 1s") == NetemSpec(delay_ms=1000.0)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "empty"),
        ("delay", "unexpected 'delay'"),
        ("delay 20", "expected a time like 20ms"),
        ("loss 2", "expected a percentage"),
        ("loss 100%", "--partition cuts a host off"),
        ("delay 10ms 20ms", "jitter 20 ms exceeds the delay 10 ms"),
        ("delay 20ms rate 1mbit", "unexpected 'rate'"),
        ("delay 20ms delay 30ms", "unexpected 'delay'"),
    ],
)
def test_bad_netem_spec(text: str, expected: str) -> None:
    with pytest.raises(FaultSpecError, match=expected):
        NetemSpec.parse(text)


def test_partition_parses_and_refuses() -> None:
    assert Partition.parse("1:5:10", 4) == Partition(1, 5.0, 10.0)
    for text, expected in [
        ("1:5", "expected HOST:START_S:DURATION_S"),
        ("a:5:10", "expected HOST:START_S:DURATION_S"),
        ("4:5:10", "host 4 is not one of 0..3"),
        ("1:5:0", "DURATION_S > 0"),
        ("1:-1:5", "START_S >= 0"),
    ]:
        with pytest.raises(FaultSpecError, match=expected):
            Partition.parse(text, 4)
    with pytest.raises(FaultSpecError, match="overlapping cuts of host 1"):
        check_partitions([Partition(1, 5, 10), Partition(2, 6, 1), Partition(1, 14, 2)])
    check_partitions([Partition(1, 5, 10), Partition(1, 15, 2)])


def _one_line_error(args: list[str]) -> str:
    result = subprocess.run(
        [WILDFIRE, "run", "--aircraft", "2", "--duration", "5", *args],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    return result.stderr


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--netem", "delay 20ms"], "--netem: only with --hosts"),
        (["--partition", "1:5:10"], "--partition: only with --hosts"),
    ],
)
def test_faults_need_hosts(args: list[str], expected: str) -> None:
    assert expected in _one_line_error(args)


@needs_namespaces
@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--netem", "delay 20ms jitter"], "--netem 'delay 20ms jitter': unexpected 'jitter'"),
        (["--partition", "5:1:1"], "--partition '5:1:1': host 5 is not one of 0..3"),
        (["--partition", "1:x:1"], "expected HOST:START_S:DURATION_S"),
    ],
)
def test_bad_fault_option_is_one_line(args: list[str], expected: str) -> None:
    assert expected in _one_line_error(["--hosts", "4", *args])


def test_bench_network_without_root_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    from wildfire_cli import bench
    from wildfire_cli.common import UserError

    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    args = argparse.Namespace(only=["network"], quick=True, device="cpu", json=True)
    with pytest.raises(UserError, match="bench network: creating network namespaces needs root"):
        bench.run(args)


# --- on virtual hosts ----------------------------------------------------------------------------


@needs_namespaces
@pytest.mark.dds
@pytest.mark.slow
@pytest.mark.timeout(RUN_TIMEOUT_S + 30)
@pytest.mark.parametrize("backend", BACKENDS)
def test_realtime_with_netem_and_a_partition_recovers(backend: str, tmp_path: Path) -> None:
    require_backend(backend, own_pass_only=True)
    args = ["--aircraft", "2", "--policy", "rh", "--seed", "3", "--realtime", "--duration", "20"]
    args += ["--hosts", "4", "--netem", "delay 20ms 10ms loss 2%", "--partition", "1:4:6"]
    summary, stderr = _run([*args, "--log-dir", str(tmp_path / "logs")], backend)

    assert summary["backend"] == backend and summary["decisions"] == 200
    faults = summary["network_faults"]
    assert isinstance(faults, dict) and faults["netem"] == "delay 20ms 10ms loss 2%"
    if "switch_frames" in faults:  # the user-space switch (no sch_netem): its loss is counted
        frames = faults["switch_frames"]
        assert 0.01 < frames["dropped"] / frames["received"] < 0.03, frames
    [cut] = faults["partitions"]
    assert cut["host"] == 1 and cut["unreachable_nodes"] == ["belief_aggregator"]
    assert 4.0 <= cut["cut_at_s"] < 5.0 and 10.0 <= cut["healed_at_s"] < 11.0
    recovered = cut["heard_again_after_heal_s"]["belief_aggregator"]
    assert recovered is not None and recovered <= RECOVERY_TARGET_S, cut
    at_cut, at_heal, at_end = cut["belief_stamp_ns_at_cut_heal_end"]
    # Nothing fresh from the cut-off aggregator during the cut (a belief already on the wire
    # may land just after it), fresher beliefs after the heal: the stamp held only grows.
    assert at_cut <= at_heal <= at_cut + 500_000_000 and at_end > at_heal + 5_000_000_000
    assert "cut off at" in stderr and "unreachable, not dead: belief_aggregator" in stderr
    assert "died" not in stderr
    assert summary["belief_iou"] > 0.0  # type: ignore[operator]


@needs_namespaces
@pytest.mark.dds
@pytest.mark.slow
@pytest.mark.timeout(RUN_TIMEOUT_S + 30)
@pytest.mark.parametrize("backend", BACKENDS)
def test_lockstep_partition_resumes_and_equals_eval(backend: str, tmp_path: Path) -> None:
    from wildfire_learning.evaluate import evaluate
    from wildfire_learning.vec_policies import make_vec_policy
    from wildfire_world.env import EnvConfig

    require_backend(backend, own_pass_only=True)
    # The cut starts half a second after the first tick: a lockstep run flies as fast as the
    # machine allows (15 simulated seconds took under 2 s on a quiet machine), so a later
    # start could fall after the last tick, and the run would never see its cut.
    n, seed, duration = 2, 5, 40.0
    args = ["--aircraft", str(n), "--policy", "rh", "--seed", str(seed), "--fast"]
    args += ["--duration", str(duration), "--wind", "0.3,-0.2", "--hosts", "4"]
    args += ["--partition", "2:0.5:4", "--log-dir", str(tmp_path / "logs")]
    summary, stderr = _run(args, backend)

    [cut] = summary["network_faults"]["partitions"]  # type: ignore[index]
    assert cut["cut_at_s"] is not None and cut["healed_at_s"] is not None
    assert cut["unreachable_nodes"] == ["uav0"]
    assert cut["heard_again_after_heal_s"]["uav0"] is not None, stderr

    config = EnvConfig(
        n_aircraft=n, shapes=("circular",), wind=(0.3, -0.2), max_duration_s=duration
    )
    reference = evaluate(make_vec_policy("rh"), config, [seed], record=True).episodes[0]
    assert summary["score"] == reference.score
    assert summary["decisions"] == reference.decisions
    assert reference.trajectory is not None
    steps = np.diff(reference.trajectory, axis=0)
    flown = np.hypot(steps[..., 0], steps[..., 1]).sum(axis=0)
    assert summary["distance_flown_m"] == flown.tolist()
