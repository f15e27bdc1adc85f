"""Rewards, pairwise states and the receding-horizon planner on hand-built cases."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_agent import pairwise
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.rewards import (
    ObservationRewardWeights,
    fire_field_maps,
    fire_terms,
    observation_rewards,
)


def strip_fire() -> np.ndarray:
    burning = np.zeros((1, 100, 100), dtype=bool)
    burning[0, :, 50] = True  # a north-south line of fire at x = 505 m
    return burning


def test_observation_reward_terms():
    w = ObservationRewardWeights()
    maps = fire_field_maps(strip_fire())
    x = np.array([[505.0, 705.0]])
    y = np.array([[505.0, 505.0]])
    rewards = observation_rewards(maps, x, y, np.array([[0.0, 0.0]]), w)
    # Over the line: distance 0, 81 - 11 = 70 clear cells; proximity to the other at 200 m.
    proximity = np.exp(-200.0 / w.proximity_scale_m)
    assert rewards[0, 0] == pytest.approx(-70 / 81 - proximity)
    assert rewards[0, 1] == pytest.approx(-200 / 500 - 1.0 - proximity)
    banked = observation_rewards(maps, x[:, :1], y[:, :1], np.array([[0.5]]), w)
    assert banked[0, 0] == pytest.approx(-70 / 81 - w.bank * 0.25)


def test_distance_is_capped_and_off_map_cells_count_as_clear():
    maps = fire_field_maps(strip_fire())
    far = fire_terms(maps, np.array([0, 0]), np.array([-2000.0, 1500.0]), np.array([505.0, 505.0]))
    assert far.tolist() == [-2.0, -2.0]


def test_disc_count_map_equals_direct_count():
    rng = np.random.default_rng(1)
    burning = rng.random((2, 100, 100)) < 0.4
    direct = fire_field_maps(burning)
    mapped = fire_field_maps(burning, with_clear_count=True)
    env = np.repeat([0, 1], 300)
    x, y = rng.uniform(-150, 1150, 600), rng.uniform(-150, 1150, 600)
    np.testing.assert_array_equal(fire_terms(direct, env, x, y), fire_terms(mapped, env, x, y))


def test_pairwise_states():
    state = AircraftState(
        x_m=np.array([0.0, 100.0]),
        y_m=np.array([0.0, 100.0]),
        heading_rad=np.array([0.0, np.pi / 2]),
        bank_steps=np.array([2, -3]),
    )
    raw = pairwise.pairwise_states(state)
    assert raw.shape == (2, 1, 5)
    phi0, rho, theta, psi, phi1 = raw[0, 0]
    assert rho == pytest.approx(np.hypot(100, 100))
    assert theta == pytest.approx(np.pi / 4)
    assert psi == pytest.approx(np.pi / 2)
    assert (phi0, phi1) == pytest.approx((np.deg2rad(10), np.deg2rad(-15)))
    # Seen from the second aircraft (heading north), the first is behind-left.
    assert raw[1, 0, 2] == pytest.approx(3 * np.pi / 4)
    alone = pairwise.pairwise_states(AircraftState(*(f[:1] for f in state)))
    assert alone.shape == (1, 1, 5) and alone[0, 0, 1] == pairwise.MAX_RANGE_M
    normalised = pairwise.normalise(raw)
    assert normalised.dtype == np.float32 and np.abs(normalised).max() <= 3.0
