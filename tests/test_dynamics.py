"""Dubins aircraft: turn radius, bank limits, exact integration."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_agent import dynamics
from wildfire_agent.dynamics import AircraftState, wrap_angle
from wildfire_sim.seeding import Stream, generator


def one(x=0.0, y=0.0, heading=0.0, bank_steps=0) -> AircraftState:
    return AircraftState(np.array([x]), np.array([y]), np.array([heading]), np.array([bank_steps]))


@pytest.mark.parametrize("bank_steps", [2, 6, 10, -4])
def test_turn_radius_is_v_squared_over_g_tan_bank(bank_steps):
    bank = bank_steps * dynamics.BANK_STEP_RAD
    radius = dynamics.SPEED_MPS**2 / (dynamics.GRAVITY_MPS2 * np.tan(abs(bank)))
    state = one(bank_steps=bank_steps)
    xs, ys = [], []
    for _ in range(400):
        state = dynamics.propagate(state)
        xs.append(state.x_m[0])
        ys.append(state.y_m[0])
    # Heading 0 at the origin: the centre is straight left (bank > 0) or right of it.
    centre_y = np.sign(bank) * radius
    distances = np.hypot(np.array(xs), np.array(ys) - centre_y)
    np.testing.assert_allclose(distances, radius, rtol=1e-9)


def test_straight_flight_covers_v_dt():
    state = dynamics.propagate(one(heading=np.pi / 2))
    assert state.x_m[0] == pytest.approx(0.0, abs=1e-12)
    assert state.y_m[0] == pytest.approx(2.0)


def test_actions_change_bank_by_five_degrees_within_the_limit():
    bank = np.array([0, 10, -10, 9])
    assert dynamics.apply_action(bank, np.array([1, 1, 0, 1])).tolist() == [1, 10, -10, 10]
    assert dynamics.apply_action(bank, np.array([0, 0, 1, 0])).tolist() == [-1, 9, -9, 8]
    assert np.rad2deg(10 * dynamics.BANK_STEP_RAD) == pytest.approx(50.0)


def test_wrap_angle_range():
    angles = wrap_angle(np.array([np.pi, -np.pi, 3 * np.pi, 0.1 - 4 * np.pi]))
    np.testing.assert_allclose(angles, [np.pi, np.pi, np.pi, 0.1])


def test_start_poses_ring_around_the_fire():
    poses = dynamics.start_poses(generator(5, Stream.SCENARIO), 200, (505.0, 505.0))
    distance = np.hypot(poses.x_m - 505.0, poses.y_m - 505.0)
    assert distance.min() >= 150.0 and distance.max() <= 300.0
    assert (poses.bank_steps == 0).all()
    assert np.ptp(poses.heading_rad) > 5.0
