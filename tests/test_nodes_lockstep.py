"""The three node types wired in one process (SingleThreadedExecutor), lockstep mode.

A short episode must reproduce the environment bit for bit: trajectories, the shared
belief, its exact ages and the team score equal what ``WildfireVecEnv`` computes for the
same seed with the same policy (``wildfire_learning.evaluate``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig, WildfireVecEnv, draw_scenario

pytestmark = [pytest.mark.dds, pytest.mark.timeout(120)]


def build_system(rt: Any, seed: int, n: int, duration: float, policy: str) -> list[Any]:
    from wildfire_agent.agent_node import AgentNode
    from wildfire_belief.belief_aggregator_node import BeliefAggregatorNode
    from wildfire_sim.fire_simulator_node import FireSimulatorNode

    config = EnvConfig(n_aircraft=n, shapes=("circular",), max_duration_s=duration)
    scenario = draw_scenario(seed, config)

    def params(**values: Any) -> list[Any]:
        return [rt.Parameter(name, value=value) for name, value in values.items()]

    nodes = [
        FireSimulatorNode(
            parameter_overrides=params(
                seed=seed,
                shape="circular",
                wind_x=float(scenario.wind[0]),
                wind_y=float(scenario.wind[1]),
                duration_s=duration,
                n_aircraft=n,
            )
        ),
        BeliefAggregatorNode(parameter_overrides=params(seed=seed, shape="circular", n_aircraft=n)),
    ]
    for k in range(n):
        nodes.append(
            AgentNode(
                namespace=f"/uav{k}",
                parameter_overrides=params(
                    aircraft=k,
                    n_aircraft=n,
                    seed=seed,
                    policy=policy,
                    start_x=float(scenario.start.x_m[k]),
                    start_y=float(scenario.start.y_m[k]),
                    start_heading=float(scenario.start.heading_rad[k]),
                ),
            )
        )
    return nodes


def run_lockstep(rt: Any, nodes: list[Any], timeout: float = 90.0) -> None:
    executor = rt.SingleThreadedExecutor()
    for node in nodes:
        executor.add_node(node)
    end = time.monotonic() + timeout
    while not nodes[0].complete and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.1)
    assert nodes[0].complete, "the lockstep episode did not finish"


@pytest.mark.parametrize(
    ("policy", "n", "duration"),
    [("rh", 2, 30.0), ("rh-paper", 2, 30.0), ("rh-belief", 2, 20.0), ("random", 3, 20.0)],
)
def test_lockstep_nodes_equal_the_environment(
    ros_runtime: Any, policy: str, n: int, duration: float
) -> None:
    seed = 11
    nodes = build_system(ros_runtime, seed, n, duration, policy)
    try:
        run_lockstep(ros_runtime, nodes)
        fire, aggregator, agents = nodes[0], nodes[1], nodes[2:]

        config = EnvConfig(n_aircraft=n, shapes=("circular",), max_duration_s=duration)
        env = WildfireVecEnv(config.__class__(**{**config.__dict__, "observation": "none"}), 1)
        observations = env.reset([seed])
        vec_policy = make_vec_policy(policy)
        vec_policy.reset(env)
        while not env.done.all():
            observations = env.step(vec_policy.act(env, observations)).observations

        assert fire.episode.decisions == env.decisions[0]
        assert np.array_equal(fire.episode.burning, env.fire.burning[0])
        for k, agent in enumerate(agents):
            assert agent.state.x_m[0] == env.aircraft.x_m[0, k]
            assert agent.state.heading_rad[0] == env.aircraft.heading_rad[0, k]
            assert agent.state.bank_steps[0] == env.aircraft.bank_steps[0, k]
        assert aggregator.aggregator.score == env.scores[0]
        assert np.array_equal(aggregator.aggregator.burning, env.belief.burning[0])
        assert np.array_equal(aggregator.aggregator.age_s(), env.belief.age_s()[0])
        summary = evaluate(make_vec_policy(policy), config, [seed])
        assert summary.episodes[0].score == aggregator.aggregator.score
    finally:
        for node in nodes:
            node.destroy_node()
