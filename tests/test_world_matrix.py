"""Every combination of the world's options flies, or is refused in one line with its reason.

Options: sensor (disc, camera), radio (ideal, none, ``range=300,loss=0.2``), wind filter
(off, on), mode (eval, lockstep, real time) and hosts (1, 2; a system option: ``eval`` flies
no system). Each combination is one case, short (2 s of flight):

* refused: ``wildfire eval`` and ``wildfire run`` say why in one line, exit status 2 (a
  wind filter needs noisy reports, and the team's every report: with ideal links);
* eval: ``evaluate`` flies it (the reference);
* lockstep: ``wildfire run --fast`` equals the reference, score and decisions;
* real time: ``wildfire run --realtime`` flies every decision of the flight.
"""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
from pathlib import Path

import pytest

from wildfire_belief.radio import CommModel
from wildfire_cli import main
from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_testbed import hosts as virtual_hosts
from wildfire_world.env import EnvConfig

pytestmark = [pytest.mark.dds, pytest.mark.timeout(240)]
WILDFIRE = str(Path(sys.executable).parent / "wildfire")
SEED, AIRCRAFT, DURATION_S, POLICY = 2000021, 2, 2.0, "rh-belief"
SENSORS = ("disc", "camera")
COMMS = ("ideal", "none", "range=300,loss=0.2")
MODES = ("eval", "lockstep", "realtime")


def refusal(sensor: str, comm: str, wind_filter: bool) -> str | None:
    """Why a world is refused (a part of the one line), or None when it flies."""
    if wind_filter and sensor == "disc":
        return "wind filter: expected noisy reports"
    if wind_filter and comm != "ideal":
        return "fly it with --comm ideal"
    return None


def world_args(sensor: str, comm: str, wind_filter: bool) -> list[str]:
    args = ["--sensor", sensor, "--comm", comm, "--seed", str(SEED), "--duration", str(DURATION_S)]
    return [*args, "--wind-filter"] if wind_filter else args


CASES = [
    (sensor, comm, wind, mode, hosts)
    for sensor, comm, wind, mode, hosts in itertools.product(
        SENSORS, COMMS, (False, True), MODES, (1, 2)
    )
    if not (mode == "eval" and hosts > 1)
]


@pytest.mark.parametrize(("sensor", "comm", "wind_filter", "mode", "hosts"), CASES)
def test_every_combination_flies_or_is_refused_with_its_reason(
    sensor: str,
    comm: str,
    wind_filter: bool,
    mode: str,
    hosts: int,
    dds_env: dict[str, str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    reason = refusal(sensor, comm, wind_filter)
    if reason is not None:
        command = "eval" if mode == "eval" else "run"
        extra = ["--realtime"] if mode == "realtime" else []
        extra += ["--hosts", str(hosts)] if hosts > 1 else []
        status = main([command, *world_args(sensor, comm, wind_filter), *extra])
        lines = capsys.readouterr().err.strip().splitlines()
        assert status == 2 and len(lines) == 1 and reason in lines[0], lines
        return
    pixel_error = 0.1 if sensor == "camera" else 0.0
    config = EnvConfig(
        n_aircraft=AIRCRAFT, shapes=("circular",), max_duration_s=DURATION_S, sensor=sensor,
        pixel_error=pixel_error, comm=CommModel.parse(comm), wind_filter=wind_filter,
    )  # fmt: skip
    expected = evaluate(make_vec_policy(POLICY), config, [SEED]).episodes[0]
    assert expected.decisions == DURATION_S * 10
    if mode == "eval":
        return
    if hosts > 1 and virtual_hosts.namespaces_unavailable() is not None:
        pytest.skip(str(virtual_hosts.namespaces_unavailable()))
    extra = ["--fast"] if mode == "lockstep" else ["--realtime"]
    extra += ["--hosts", str(hosts)] if hosts > 1 else []
    result = subprocess.run(
        [WILDFIRE, "run", "--policy", POLICY, "--aircraft", str(AIRCRAFT), "--json",
         "--log-dir", str(tmp_path / "logs"), *world_args(sensor, comm, wind_filter), *extra],
        env=dds_env, capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["comm"] == comm and summary["decisions"] == expected.decisions
    if mode == "lockstep":
        assert summary["score"] == expected.score
