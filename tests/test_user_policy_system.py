"""A policy of your own (``MODULE:ATTR``) in the distributed system: each agent node flies
it for its one aircraft, and lockstep equals ``wildfire eval`` bit for bit, in process
(both backends) and through ``wildfire run``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from test_nodes_lockstep import build_system, run_lockstep
from test_user_policy import EXAMPLE, WEAVE
from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig

pytestmark = [pytest.mark.dds, pytest.mark.timeout(180)]
WILDFIRE = str(Path(sys.executable).parent / "wildfire")


@pytest.fixture
def weave(tmp_path: Path) -> str:
    path = tmp_path / "weave.py"
    path.write_text(WEAVE)
    return f"{path}:make"


@pytest.mark.parametrize(("which", "n", "duration"), [("example", 2, 20.0), ("weave", 3, 15.0)])
def test_agent_nodes_fly_it_as_the_environment_does(
    ros_runtime: Any, weave: str, which: str, n: int, duration: float
) -> None:
    name = f"{EXAMPLE}:StalestFirePolicy" if which == "example" else weave
    seed = 11
    nodes = build_system(ros_runtime, seed, n, duration, name)
    try:
        run_lockstep(ros_runtime, nodes)
        aggregator, agents = nodes[1], nodes[2:]
        config = EnvConfig(n_aircraft=n, shapes=("circular",), max_duration_s=duration)
        reference = evaluate(make_vec_policy(name), config, [seed], record=True).episodes[0]
        assert reference.trajectory is not None
        for k, agent in enumerate(agents):
            final = [agent.state.x_m[0], agent.state.y_m[0]]
            assert np.array_equal(final, reference.trajectory[-1, k])
        assert aggregator.aggregator.score == reference.score
    finally:
        for node in nodes:
            node.destroy_node()


@pytest.mark.slow
def test_run_flies_a_policy_from_outside_the_repository(
    tmp_path: Path, dds_env: dict[str, str], weave: str
) -> None:
    seed, duration = 4, 20.0
    args = ["run", "--aircraft", "2", "--policy", weave, "--seed", str(seed)]
    args += ["--duration", str(duration), "--fast", "--json", "--log-dir", str(tmp_path / "logs")]
    result = subprocess.run(
        [WILDFIRE, *args], env=dds_env, capture_output=True, text=True, timeout=150
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    config = EnvConfig(shapes=("circular",), max_duration_s=duration)
    reference = evaluate(make_vec_policy(weave), config, [seed], record=True).episodes[0]
    assert summary["score"] == reference.score
    assert summary["decisions"] == reference.decisions
