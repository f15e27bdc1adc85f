"""The batched environment, its PettingZoo wrapper, policies and evaluation."""

from __future__ import annotations

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig, WildfireVecEnv
from wildfire_world.errors import WorldError
from wildfire_world.parallel_env import WildfireParallelEnv


def rollout(env: WildfireVecEnv, seeds, steps: int, action_seed: int = 0):
    observations = env.reset(seeds)
    rng = np.random.default_rng(action_seed)
    poses, rewards, scores = [], [], []
    for _ in range(steps):
        result = env.step(rng.integers(0, 2, size=(env.num_envs, env.config.n_aircraft)))
        poses.append(np.stack([env.aircraft.x_m, env.aircraft.y_m], -1).copy())
        rewards.append(result.rewards)
        scores.append(env.scores.copy())
    return observations, np.array(poses), np.array(rewards), np.array(scores)


@pytest.mark.parametrize("observation", ["obs", "belief"])
def test_environment_is_deterministic_per_seed(observation):
    config = EnvConfig(observation=observation, reward=observation, shapes=("circular", "arc"))
    first = rollout(WildfireVecEnv(config, 2), [7, 8], 80)
    second = rollout(WildfireVecEnv(config, 2), [7, 8], 80)
    for a, b in zip(first, second, strict=True):
        if isinstance(a, dict):
            for key in a:
                np.testing.assert_array_equal(a[key], b[key])
        else:
            np.testing.assert_array_equal(a, b)


def test_an_episode_does_not_depend_on_its_batch():
    config = EnvConfig(observation="belief", reward="belief", n_aircraft=3)
    batch = WildfireVecEnv(config, 3)
    alone = WildfireVecEnv(config, 1)
    batch.reset([4, 9, 2])
    alone.reset([9])
    rng = np.random.default_rng(3)
    for _ in range(120):
        actions = rng.integers(0, 2, size=(3, 3))
        batch_result = batch.step(actions)
        alone_result = alone.step(actions[1:2])
        np.testing.assert_array_equal(batch_result.rewards[1], alone_result.rewards[0])
        np.testing.assert_array_equal(
            batch_result.observations["image"][1], alone_result.observations["image"][0]
        )
    np.testing.assert_array_equal(batch.aircraft.x_m[1], alone.aircraft.x_m[0])
    assert batch.scores[1] == alone.scores[0]


def test_observation_shapes_and_episode_end():
    config = EnvConfig(n_aircraft=3, wind=(0.8, 0.0))
    env = WildfireVecEnv(config, 2)
    observations = env.reset([1, 2])
    assert observations["image"].shape == (2, 3, 1, 30, 40)
    assert observations["state"].shape == (2, 3, 2, 5)
    steps = 0
    while not env.done.all():
        env.step(np.zeros((2, 3), dtype=np.int64))
        steps += 1
    # A strong east wind drives the fire to the border well before 400 s, on a fire step.
    assert env.terminated.all()
    assert (env.decisions % 25 == 0).all() and env.decisions.max() < 4000
    frozen = env.aircraft.x_m.copy()
    env.step(np.ones((2, 3), dtype=np.int64))
    np.testing.assert_array_equal(env.aircraft.x_m, frozen)


def test_duration_truncates():
    env = WildfireVecEnv(EnvConfig(max_duration_s=12.0, wind=(0.0, 0.0)), 1)
    env.reset([0])
    result = None
    for _ in range(120):
        result = env.step(np.zeros((1, 2), dtype=np.int64))
    assert result is not None and result.truncated[0] and not env.terminated[0]


def test_pettingzoo_conformance():
    parallel_api_test(WildfireParallelEnv(EnvConfig(max_duration_s=15.0)), num_cycles=200)
    parallel_seed_test(lambda: WildfireParallelEnv(EnvConfig(max_duration_s=5.0)))


def test_bad_configuration_is_named():
    with pytest.raises(WorldError, match="aircraft"):
        EnvConfig(n_aircraft=0).validate()
    with pytest.raises(WorldError, match="observation"):
        EnvConfig(observation="camera").validate()


def test_receding_horizon_beats_random():
    config = EnvConfig(n_aircraft=2, max_duration_s=60.0)
    seeds = list(range(500, 504))
    rh = evaluate(make_vec_policy("rh"), config, seeds, "rh")
    random = evaluate(make_vec_policy("random"), config, seeds, "random")
    assert rh.scores.mean() > 1.5 * random.scores.mean()
    assert (rh.scores >= random.scores).sum() >= 3
    # The ceiling is a property of the fire alone, and no policy scores above it.
    np.testing.assert_array_equal(rh.score_ceilings, random.score_ceilings)
    assert np.all(rh.scores <= rh.score_ceilings)
    assert np.all(random.scores <= random.score_ceilings)
    assert rh.to_json()["ceiling_fraction"] > random.to_json()["ceiling_fraction"] > 0.0
