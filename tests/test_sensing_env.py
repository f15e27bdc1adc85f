"""Noisy sensing in the environment: the noise asked for, the score counted once, the batch
never changing an episode, the paper's disc untouched."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig, WildfireVecEnv
from wildfire_world.errors import WorldError


def fly(config: EnvConfig, seeds: list[int], decisions: int) -> tuple[WildfireVecEnv, int]:
    env = WildfireVecEnv(config, len(seeds))
    env.reset(seeds)
    rng = np.random.default_rng(3)
    total = 0
    for _ in range(decisions):
        total += int(env.step(rng.integers(0, 2, size=(len(seeds), 2))).team_reward.sum())
    return env, total


def test_the_paper_disc_keeps_the_shared_belief() -> None:
    env = WildfireVecEnv(EnvConfig(), 1)
    assert env.sensing is None


@pytest.mark.parametrize("sensor", ["camera", "disc"])
def test_the_fraction_of_flipped_reports_is_the_pixel_error(sensor: str) -> None:
    config = EnvConfig(sensor=sensor, pixel_error=0.1, observation="none", reward="belief")
    env, _ = fly(config, [11, 12], 600)
    assert env.sensing is not None
    assert env.sensing.reports.min() > 50_000
    assert np.all(np.abs(env.sensing.flipped_fraction() - 0.1) <= 0.01)


def test_belief_images_show_the_published_probability_under_noise() -> None:
    from wildfire_msgs_py.belief_codec import belief_probability, belief_to_msg
    from wildfire_msgs_py.codecs import grid_from_msg

    config = EnvConfig(sensor="camera", pixel_error=0.1, observation="belief", reward="belief")
    env, _ = fly(config, [41], 300)
    assert env.sensing is not None
    belief = env.sensing.belief
    msg = belief_to_msg(belief.believed()[0], probability=belief.probability()[0])
    shown = env.belief_probability()
    # Exactly what an agent decodes from /wildfire/belief, and not only 0 or 1.
    assert np.array_equal(shown[0], belief_probability(grid_from_msg(msg)))
    assert np.unique(shown).size > 10
    channel = env.observe()["image"][0, :, 0]
    assert set(np.unique(channel)) <= set(np.unique(shown)) | {0.0}
    assert np.unique(channel).size > 2
    paper = WildfireVecEnv(replace(config, sensor="disc", pixel_error=0.0), 1)
    paper.reset([41])
    assert paper.belief_probability().dtype == bool  # the believed map itself


def test_a_cell_scores_at_most_once_and_only_while_burning() -> None:
    config = EnvConfig(sensor="camera", pixel_error=0.1, observation="none", reward="belief")
    env, total = fly(config, [21, 22], 900)
    assert env.sensing is not None
    scored = env.sensing.scored
    assert total == int(env.scores.sum()) == int(scored.sum()) > 0
    # Every scored cell burned at some point: it is burning or burnt out now.
    assert not (scored & ~env.fire.affected()).any()


def test_an_episode_under_noise_does_not_depend_on_its_batch() -> None:
    config = EnvConfig(sensor="camera", pixel_error=0.1, max_duration_s=40.0)
    policy = make_vec_policy("rh-belief")
    together = evaluate(policy, config, [31, 32, 33]).to_json()
    alone = evaluate(make_vec_policy("rh-belief"), config, [32]).to_json()
    assert together["scores"][1] == alone["scores"][0]
    assert together["false_alarms"][1] == alone["false_alarms"][0]


@pytest.mark.parametrize(
    ("changes", "names"),
    [
        ({"sensor": "radar"}, "sensor: expected one of"),
        ({"sensor": "camera", "pixel_error": 0.5}, "pixel error"),
        ({"pixel_error": -0.1}, "pixel error"),
        ({"pixel_error": 0.1, "observation": "obs"}, "needs --sensor camera"),
    ],
)
def test_bad_sensing_settings_name_what_was_expected(changes: dict, names: str) -> None:
    with pytest.raises(WorldError, match=names):
        EnvConfig(**changes).validate()


def test_under_noise_no_policy_scores_above_the_ceiling() -> None:
    config = EnvConfig(sensor="camera", pixel_error=0.1, max_duration_s=30.0)
    summary = evaluate(make_vec_policy("rh-belief"), config, [41, 42]).to_json()
    assert all(
        0 < s <= c for s, c in zip(summary["scores"], summary["score_ceilings"], strict=True)
    )


def test_the_wind_filter_feeds_its_estimate_to_the_belief_and_keeps_episodes_apart() -> None:
    config = EnvConfig(sensor="camera", pixel_error=0.1, wind_filter=True, max_duration_s=8.0)
    together = evaluate(make_vec_policy("rh-belief"), config, [51, 52]).to_json()
    alone = evaluate(make_vec_policy("rh-belief"), config, [52]).to_json()
    assert together["scores"][1] == alone["scores"][0]
    env, _ = fly(replace(config, observation="none", reward="belief"), [53], 60)
    assert env.sensing is not None
    assert np.any(env.sensing.belief.wind[0] != 0.0)  # two fire steps: the estimate is in
    with pytest.raises(WorldError, match="wind filter"):
        EnvConfig(sensor="camera", pixel_error=0.0, wind_filter=True).validate()
