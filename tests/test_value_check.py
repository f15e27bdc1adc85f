"""The value check of training evaluations: predicted values against collected returns."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_learning.validation import mean_reward, value_check


def steps(values: list[float]) -> list[np.ndarray]:
    """One (E=1, N=1) array per step."""
    return [np.array([[v]]) for v in values]


def test_an_episode_the_fire_ended_checks_every_decision() -> None:
    # Rewards 1, 1, 1 with gamma 0.5: returns 1.75, 1.5, 1 (scale 2: twice that).
    check = value_check(
        steps([2.0, 2.0, 2.0, 9.0]),
        steps([1.0, 1.0, 1.0, 0.0]),
        [np.array([True])] * 3 + [np.array([False])],
        np.array([True]),
        gamma=0.5,
        reward_scale=2.0,
    )
    assert check.decisions == 3
    assert check.predicted == pytest.approx(2.0)
    assert check.collected == pytest.approx(2.0 * (1.75 + 1.5 + 1.0) / 3)


def test_a_time_limit_cut_drops_decisions_whose_return_is_unknown() -> None:
    # gamma 0.5: rewards 7 or more steps ahead weigh < 1 %, so of 10 decisions cut by the
    # time limit only the first 3 are checked.
    check = value_check(
        steps(list(range(10))),
        steps([1.0] * 10),
        [np.array([True])] * 10,
        np.array([False]),
        gamma=0.5,
        reward_scale=1.0,
    )
    assert check.decisions == 3
    assert check.predicted == pytest.approx(1.0)
    assert 1.99 < check.collected < 2.0


def test_mean_reward_counts_the_decisions_of_stepped_episodes_only() -> None:
    # Two episodes of two aircraft; the second stops after the first step, and its later
    # (zero) rewards must not dilute the mean.
    rewards = [np.array([[1.0, 3.0], [5.0, 7.0]]), np.array([[2.0, 2.0], [0.0, 0.0]])]
    active = [np.array([True, True]), np.array([True, False])]
    assert mean_reward(rewards, active) == pytest.approx((1 + 3 + 5 + 7 + 2 + 2) / 6)
