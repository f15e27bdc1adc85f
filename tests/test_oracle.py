"""The clairvoyant bound ``oracle`` (wildfire_learning/oracle.py, docs/model.md, Baselines):
its known future is the environment's fire, its coverage score is the environment's score,
the environment flies its plan to the score it predicts, and it beats ``rh``."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from wildfire_agent import dynamics
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.policy_names import make_policy
from wildfire_learning.evaluate import TEST_SEED_BASE, evaluate
from wildfire_learning.oracle import (
    OracleConfig,
    coverage_score,
    fly,
    known_future,
    plan_episode,
)
from wildfire_learning.oracle_incumbents import INCUMBENT_POLICIES
from wildfire_learning.oracle_kernels import NEVER
from wildfire_learning.oracle_policy import OracleVecPolicy
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_sim.episode import DECISIONS_PER_FIRE_STEP
from wildfire_sim.grid import PAPER_MAP
from wildfire_world.env import EnvConfig, WildfireVecEnv

WILDFIRE = str(Path(sys.executable).with_name("wildfire"))
SEED = TEST_SEED_BASE + 7


def short_config(duration_s: float = 30.0, n_aircraft: int = 2) -> EnvConfig:
    return EnvConfig(
        n_aircraft=n_aircraft, observation="none", max_duration_s=duration_s
    ).validate()


def burning_at(future, step: int) -> np.ndarray:
    """(H, W) scorable cells burning at fire step ``step`` by the known future."""
    on = (future.start_step <= step) & (step < future.end_step)
    return on.reshape(PAPER_MAP.shape)


@pytest.mark.parametrize("seed", [SEED, TEST_SEED_BASE + 18])
def test_known_future_is_the_environment_fire(seed):
    # Long enough to see fire steps and, for the windy seed 18, the border ending.
    config = short_config(duration_s=400.0)
    future = known_future(seed, config)
    env = WildfireVecEnv(config, 1)
    env.reset([seed])
    scorable = ~env.belief.burning[0]
    start = env.aircraft.copy()
    assert np.array_equal(start.x_m[0], future.start.x_m)
    assert np.array_equal(start.heading_rad[0], future.start.heading_rad)
    assert np.array_equal(env.truth[0] & scorable, burning_at(future, 0))
    while not env.done[0]:
        env.step(np.zeros((1, 2), np.int64))
        step = int(env.decisions[0]) // DECISIONS_PER_FIRE_STEP
        if env.decisions[0] % DECISIONS_PER_FIRE_STEP == 0:
            assert np.array_equal(env.truth[0] & scorable, burning_at(future, step))
    assert int(env.decisions[0]) == future.decisions
    assert future.ceiling == int((future.start_step < NEVER).sum())


def test_fly_is_the_dynamics_float_for_float():
    rng = np.random.default_rng(3)
    start = dynamics.AircraftState(
        x_m=rng.uniform(0, 1000, 3),
        y_m=rng.uniform(0, 1000, 3),
        heading_rad=dynamics.wrap_angle(rng.uniform(-4, 4, 3)),
        bank_steps=np.array([-10, 0, 7]),
    )
    actions = rng.integers(0, 2, (3, 400))
    actions[0, :50] = 0  # pushing into the bank limit
    xs, ys = fly(start, actions)
    state = start.copy()
    for t in range(actions.shape[1]):
        state = dynamics.step(state, actions[:, t])
        assert np.array_equal(state.x_m, xs[:, t]) and np.array_equal(state.y_m, ys[:, t])


@pytest.mark.parametrize("policy", ["random", "rh"])
def test_coverage_score_is_the_environment_score(policy):
    config = short_config(duration_s=25.0)
    seeds = [SEED, SEED + 1]
    summary = evaluate(make_vec_policy(policy), config, seeds, policy, record=True)
    for episode in summary.episodes:
        assert episode.trajectory is not None and episode.score > 0
        path = episode.trajectory[1:]  # (L, N, 2): after each decision
        future = known_future(episode.seed, config)
        assert future.decisions == episode.decisions
        assert coverage_score(future, path[..., 0].T, path[..., 1].T) == episode.score


def test_oracle_flies_what_it_predicts_and_beats_rh():
    config = short_config(duration_s=30.0)
    oracle = make_vec_policy("oracle")
    assert isinstance(oracle, OracleVecPolicy) and oracle.observation == "none"
    summary = evaluate(oracle, config, [SEED], "oracle", record=True)
    flown = summary.episodes[0]
    plan = oracle.plans[SEED]
    # The timings count the planning before the flight: its own key, the policy's time per
    # decision and the wall time all hold it.
    assert summary.planning_s >= oracle.plan_seconds[SEED] > 0.0
    assert summary.seconds_per_decision * flown.decisions * 2 >= summary.planning_s
    assert summary.wall_time_s >= summary.planning_s
    assert summary.to_json()["planning_s"] == summary.planning_s
    assert flown.score == plan.score
    assert flown.trajectory is not None
    assert np.array_equal(flown.trajectory[1:, :, 0].T, plan.x_m)
    rh = evaluate(make_vec_policy("rh"), config, [SEED], "rh").episodes[0]
    assert flown.score > rh.score, (flown.score, rh.score)
    assert flown.score <= flown.score_ceiling == known_future(SEED, config).ceiling


def test_plan_is_deterministic_and_config_matters():
    config = short_config(duration_s=10.0, n_aircraft=3)
    future = known_future(SEED, config)
    small = OracleConfig(horizon=40, replan_every=10, random_restarts=1)
    first = plan_episode(future, small)
    again = plan_episode(future, small)
    assert np.array_equal(first.actions, again.actions) and first.score == again.score
    assert first.actions.shape == (3, future.decisions)
    xs, ys = fly(future.start, first.actions)
    assert coverage_score(future, xs, ys) == first.score
    assert replace(small, horizon=20) != small


def test_agent_refuses_the_oracle():
    with pytest.raises(AgentConfigError, match="unknown policy 'oracle'"):
        make_policy("oracle")


def test_run_refuses_the_oracle_in_one_line():
    result = subprocess.run(
        [WILDFIRE, "run", "--policy", "oracle", "--aircraft", "2"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and "--policy 'oracle': expected" in lines[0], result.stderr


def test_oracle_with_incumbents_scores_at_least_each_incumbent():
    config = short_config(duration_s=20.0)
    seed = SEED + 2
    oracle = make_vec_policy("oracle")
    assert isinstance(oracle, OracleVecPolicy)
    assert oracle.config.incumbents == INCUMBENT_POLICIES
    assert INCUMBENT_POLICIES == ("rh", "rh-paper", "rh-belief", "obs", "belief", "belief-radio")
    flown = evaluate(oracle, config, [seed], "oracle").episodes[0]
    found = oracle.candidates[seed]
    assert flown.score == oracle.plans[seed].score == found["refined"]
    assert found["refined"] >= max(found.values())
    for name in INCUMBENT_POLICIES:
        incumbent = evaluate(make_vec_policy(name), config, [seed], name).episodes[0]
        assert flown.score >= incumbent.score, (name, flown.score, incumbent.score)
        if name.startswith("rh"):  # no torch: the private flight is the very same
            assert found[name] == incumbent.score
    alone = OracleVecPolicy(OracleConfig(horizon=40, incumbents=()))
    alone.plan(seed, config)
    assert set(alone.candidates[seed]) == {"search", "refined"}
    with pytest.raises(ValueError, match="no policy factory"):
        OracleVecPolicy(OracleConfig(incumbents=("rh",)))
