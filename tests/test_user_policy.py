"""Bring your own policy (``MODULE:ATTR``): loading, one-line refusals, an agent's aircraft
policy flying it exactly as the environment does, the CLI, and the two examples."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from wildfire_agent.aircraft_policy import AircraftPolicy
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.policy_names import make_policy, policy_source
from wildfire_agent.user_policy import is_user_policy, load_user_policy
from wildfire_learning.evaluate import evaluate
from wildfire_learning.results_report import policy_id
from wildfire_learning.vec_policies import UserVecPolicy, make_vec_policy
from wildfire_world.env import EnvConfig, WildfireVecEnv

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "examples" / "stalest_fire_policy.py"
WILDFIRE = str(Path(sys.executable).parent / "wildfire")

# A policy written outside the repository: poses only, its randomness one stream per aircraft
# (the decentralised rule), turning away from a close peer.
WEAVE = """
import numpy as np
from wildfire_sim.seeding import Stream, generator


class Weave:
    observation = "none"

    def reset(self, env):
        n = env.aircraft.x_m.shape[1]
        self.rngs = [[generator(int(s), Stream.AIRCRAFT, k) for k in range(n)] for s in env.seeds]

    def act(self, env, observations):
        draws = np.array([[rng.integers(2) for rng in row] for row in self.rngs])
        near = observations["state"][:, :, 0, 1] < 0.2  # normalised range to the first peer
        away = (observations["state"][:, :, 0, 2] < 0).astype(np.int64)  # peer on the right
        return np.where(near, away, draws).astype(np.int64)


def make():
    return Weave()
"""


@pytest.fixture
def weave(tmp_path: Path) -> str:
    path = tmp_path / "outside" / "weave.py"
    path.parent.mkdir()
    path.write_text(WEAVE)
    return f"{path}:make"


def write(tmp_path: Path, source: str) -> str:
    path = tmp_path / "bad_policy.py"
    path.write_text(source)
    return str(path)


@pytest.mark.parametrize(
    ("source", "attr", "expected"),
    [
        ("raise RuntimeError('boom')\n", "P", "cannot import"),
        ("x = 1\n", "P", "has no attribute 'P'"),
        ("P = 3\n", "P", "is not a class or factory"),
        ("class P:\n    observation = 'none'\n    def reset(self, env): pass\n", "P", "no act"),
        (
            "class P:\n    observation = 'map'\n    def reset(self, env): pass\n"
            "    def act(self, env, o): pass\n",
            "P",
            "observation 'map'",
        ),
        ("def P():\n    raise ValueError('no weights')\n", "P", r"P\(\) failed"),
    ],
)
def test_a_bad_policy_is_refused_in_one_line(
    tmp_path: Path, source: str, attr: str, expected: str
) -> None:
    name = f"{write(tmp_path, source)}:{attr}"
    with pytest.raises(AgentConfigError, match=expected) as error:
        load_user_policy(name)
    assert "\n" not in str(error.value) and name in str(error.value)


def test_names_resolve_in_one_place(weave: str) -> None:
    assert is_user_policy(weave) and is_user_policy("json:loads")
    assert not is_user_policy("rh") and not is_user_policy("models/obs_policy.pt")
    factory = make_policy(weave)
    assert factory.user is not None and factory.observation == "none"
    assert isinstance(make_vec_policy(weave), UserVecPolicy)
    assert policy_source(weave) == Path(weave.rpartition(":")[0])
    assert policy_source("rh") is None
    assert policy_id(weave) == "make"
    with pytest.raises(AgentConfigError, match="No module named"):
        make_policy("no_such_module_here:Policy")


def test_wrong_actions_are_refused(tmp_path: Path) -> None:
    source = (
        "import numpy as np\nclass P:\n    observation = 'none'\n"
        "    def reset(self, env): pass\n    def act(self, env, o): return np.full((1, 3), 2)\n"
    )
    policy = make_vec_policy(f"{write(tmp_path, source)}:P")
    with pytest.raises(AgentConfigError, match=r"expected \(2, 2\) actions of 0 or 1"):
        evaluate(policy, EnvConfig(max_duration_s=1.0), [1, 2])


@pytest.mark.parametrize(("which", "n"), [("example", 2), ("weave", 3)])
def test_an_aircraft_policy_flies_it_as_the_environment_does(
    weave: str, which: str, n: int
) -> None:
    """Each agent's aircraft policy, given what its node has (team poses, truth, belief),
    picks at every decision the action the environment's batch picked for it."""
    name = f"{EXAMPLE}:StalestFirePolicy" if which == "example" else weave
    policy = make_vec_policy(name)
    config = EnvConfig(n_aircraft=n, observation=policy.observation, max_duration_s=20.0)
    env = WildfireVecEnv(config, 2)
    observations = env.reset([7, 8])
    policy.reset(env)
    agents = [AircraftPolicy(name, k, n, seed=8) for k in range(n)]
    decisions = 0
    while not env.done.all():
        actions = policy.act(env, observations)
        team = AircraftState(*(field[1] for field in env.aircraft))
        belief, ages = env.belief_probability()[1], env.belief_age_s()[1]
        if not env.done[1]:
            for k, agent in enumerate(agents):
                chosen = agent.decide(team, env.truth[1], decisions, belief, ages)
                assert chosen == actions[1, k], f"aircraft {k}, decision {decisions}"
            decisions += 1
        observations = env.step(actions).observations
    assert decisions > 100


def run_cli(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess[str]:
    return subprocess.run([WILDFIRE, *args], capture_output=True, text=True, timeout=120, cwd=cwd)


def test_eval_flies_a_policy_from_outside_the_repository(weave: str, tmp_path: Path) -> None:
    args = ["--policy", weave, "--seed", "3", "--episodes", "2", "--duration", "20", "--json"]
    result = run_cli("eval", *args)
    assert result.returncode == 0, result.stderr
    config = EnvConfig(shapes=("circular",), max_duration_s=20.0)
    reference = evaluate(make_vec_policy(weave), config, [3, 4]).to_json()
    assert json.loads(result.stdout)["scores"] == reference["scores"]
    # An importable module too, from the working directory.
    module = run_cli(
        "eval", "--policy", "weave:Weave", "--episodes", "1", "--duration", "5", "--json",
        cwd=Path(weave.rpartition(":")[0]).parent,
    )  # fmt: skip
    assert module.returncode == 0, module.stderr


@pytest.mark.parametrize("command", ["eval", "report", "run"])
def test_the_cli_refuses_a_bad_policy_in_one_line(command: str, tmp_path: Path) -> None:
    option = "--policies" if command == "report" else "--policy"
    extra = ["--out", str(tmp_path / "report")] if command == "report" else []
    result = run_cli(command, option, "no_such_module_here:Policy", *extra)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert "cannot import no_such_module_here" in result.stderr


def test_the_example_beats_random() -> None:
    config = EnvConfig(shapes=("circular",), observation="belief", max_duration_s=60.0)
    seeds = list(range(6))
    mine = evaluate(make_vec_policy(f"{EXAMPLE}:StalestFirePolicy"), config, seeds)
    random = evaluate(make_vec_policy("random"), config, seeds)
    assert np.mean(mine.scores) > np.mean(random.scores)


def test_the_training_example_trains_and_flies(tmp_path: Path) -> None:
    weights = tmp_path / "reinforce.pt"
    script = REPO / "examples" / "train_reinforce.py"
    args = ["--episodes", "2", "--episode-seconds", "3", "--out", str(weights)]
    trained = subprocess.run(
        [sys.executable, str(script), *args], capture_output=True, text=True, timeout=120
    )
    assert trained.returncode == 0, trained.stderr
    assert trained.stdout.count("episode ") == 2 and weights.stat().st_size > 0
    env = {**os.environ, "REINFORCE_POLICY": str(weights)}
    flown = subprocess.run(
        [WILDFIRE, "eval", "--policy", f"{script}:ReinforcePolicy", "--episodes", "1",
         "--duration", "5", "--json"],
        capture_output=True, text=True, timeout=120, env=env,
    )  # fmt: skip
    assert flown.returncode == 0, flown.stderr
    assert json.loads(flown.stdout)["episodes"] == 1
