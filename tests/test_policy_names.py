"""One policy factory: every name is accepted by the agent's aircraft policy and by the policies,
and both fly the same actions."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from wildfire_agent.aircraft_policy import AircraftPolicy
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.policies import TorchScriptPolicy, greedy_actions
from wildfire_agent.policy_names import (
    BUILTIN_POLICIES,
    OBS_CAMERA_POLICY,
    SHIPPED_POLICIES,
    make_policy,
    resolve_policy_path,
)
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig, WildfireVecEnv

EVERY_NAME = (*BUILTIN_POLICIES, *SHIPPED_POLICIES)


@pytest.mark.parametrize("name", [*EVERY_NAME, "models/obs_policy.pt"])
def test_every_name_is_accepted_everywhere(name: str) -> None:
    if name.endswith(".pt"):
        name = str(resolve_policy_path("obs"))
    factory = make_policy(name)
    assert make_vec_policy(name).observation == factory.observation
    sensor = "camera" if name == OBS_CAMERA_POLICY else "disc"  # the world of its images
    assert AircraftPolicy(name, 1, 2, seed=3, sensor=sensor).observation == factory.observation


def test_unknown_names_fail_in_one_place() -> None:
    for build in (make_policy, make_vec_policy, lambda name: AircraftPolicy(name, 0, 2, 0)):
        with pytest.raises(AgentConfigError, match="unknown policy 'genius'"):
            build("genius")


@pytest.mark.parametrize("name", ["random", "rh-paper", "obs", "belief"])
def test_pilot_flies_what_the_controller_flies(name: str) -> None:
    vec_policy = make_vec_policy(name)
    config = EnvConfig(n_aircraft=3, observation=vec_policy.observation, max_duration_s=8.0)
    env = WildfireVecEnv(config, 1)
    observations = env.reset([11])
    vec_policy.reset(env)
    pilots = [AircraftPolicy(name, k, 3, seed=11) for k in range(3)]
    decisions = 0
    while not env.done[0]:
        team = AircraftState(*(np.array(field[0]) for field in env.aircraft))
        burning, belief = env.truth[0], env.belief.burning[0]
        ages = env.belief.age_s()[0]
        flown = [p.decide(team, burning, env.decisions[0] // 25, belief, ages) for p in pilots]
        actions = vec_policy.act(env, observations)
        np.testing.assert_array_equal(actions[0], flown)
        observations = env.step(actions).observations
        decisions += 1
    assert decisions == config.max_decisions or env.terminated[0]


def test_greedy_actions_is_the_policy_argmax() -> None:
    policy = TorchScriptPolicy(resolve_policy_path("obs"))
    rng = np.random.default_rng(0)
    images = (rng.random((6, 1, 30, 40)) < 0.3).astype(np.float32)
    states = rng.standard_normal((6, 2, 5)).astype(np.float32)
    q = policy.q_values(images, states)
    np.testing.assert_array_equal(policy.act(images, states), q.argmax(axis=1))
    np.testing.assert_array_equal(greedy_actions(policy.module, images, states), q.argmax(axis=1))

    # A tie goes to the first action (-5 degrees), in every path.
    class Flat(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.bias = torch.nn.Parameter(torch.zeros(2))

        def forward(self, images: torch.Tensor, states: torch.Tensor) -> torch.Tensor:
            return self.bias.expand(states.shape[0], states.shape[1], 2)

    assert greedy_actions(Flat(), images, states).tolist() == [0] * 6
