"""Dubins aircraft commanded by bank-angle increments at 10 Hz (docs/model.md, Aircraft).

Kinematics: ``x' = v cos(psi)``, ``y' = v sin(psi)``, ``psi' = g tan(phi) / v`` with heading psi
measured counter-clockwise from east (so a positive bank turns the aircraft to the left,
counter-clockwise) and constant speed v. The bank is constant over a decision period, so
the arc is integrated exactly (no sub-steps).

The bank angle is held as an integer number of 5-degree steps (``bank_steps`` in
[-10, 10]): the +/-5 degree actions and the 50 degree limit are then exact, with no drift
from adding 5 degrees in radians over and over.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

SPEED_MPS = 20.0
"""Airspeed v."""
GRAVITY_MPS2 = 9.81
"""Gravitational acceleration g."""
DECISION_PERIOD_S = 0.1
"""Time between two bank commands (10 Hz)."""
BANK_STEP_RAD = np.deg2rad(5.0)
"""Bank change of one action."""
MAX_BANK_STEPS = 10
"""Bank limit in steps: 10 x 5 degrees = 50 degrees."""
ACTION_BANK_DELTA = np.array([-1, 1], dtype=np.int64)
"""Bank change in steps of each action: action 0 banks -5 degrees, action 1 banks +5 degrees."""
NUM_ACTIONS = 2


class AircraftState(NamedTuple):
    """Poses of a batch of aircraft; every field has the same shape, e.g. (E, N)."""

    x_m: np.ndarray
    """East position, metres (float64)."""
    y_m: np.ndarray
    """North position, metres (float64)."""
    heading_rad: np.ndarray
    """Heading psi, counter-clockwise from east, wrapped to (-pi, pi] (float64)."""
    bank_steps: np.ndarray
    """Bank angle in 5-degree steps, in [-10, 10] (int64)."""

    @property
    def bank_rad(self) -> np.ndarray:
        """Bank angle phi in radians."""
        return self.bank_steps * BANK_STEP_RAD

    def copy(self) -> AircraftState:
        """A deep copy (the arrays are mutable)."""
        return AircraftState(*(np.array(field, copy=True) for field in self))


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Wrap radians to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=np.float64), 2.0 * np.pi)


def apply_action(bank_steps: np.ndarray, action: np.ndarray) -> np.ndarray:
    """Bank after an action: +/-1 step, unchanged if that would exceed the 50 degree limit."""
    proposed = bank_steps + ACTION_BANK_DELTA[np.asarray(action, dtype=np.int64)]
    return np.where(np.abs(proposed) > MAX_BANK_STEPS, bank_steps, proposed)


def turn_rate(bank_rad: np.ndarray) -> np.ndarray:
    """Heading rate g tan(phi) / v in rad/s."""
    return GRAVITY_MPS2 * np.tan(bank_rad) / SPEED_MPS


def _arc(
    heading_rad: np.ndarray, new_heading_rad: np.ndarray, rate: np.ndarray, dt: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(dx, dy) of flying from ``heading_rad`` to ``new_heading_rad`` at turn rate ``rate``.

    On an arc of radius v / rate: x += (v / rate)(sin(psi + rate dt) - sin(psi)), etc.;
    wings level (rate 0): a straight line.
    """
    turning = rate != 0.0
    safe_rate = np.where(turning, rate, 1.0)
    arc_dx = SPEED_MPS / safe_rate * (np.sin(new_heading_rad) - np.sin(heading_rad))
    arc_dy = SPEED_MPS / safe_rate * (np.cos(heading_rad) - np.cos(new_heading_rad))
    line_dx = SPEED_MPS * dt * np.cos(heading_rad)
    line_dy = SPEED_MPS * dt * np.sin(heading_rad)
    return np.where(turning, arc_dx, line_dx), np.where(turning, arc_dy, line_dy)


def propagate(state: AircraftState, dt: float | np.ndarray = DECISION_PERIOD_S) -> AircraftState:
    """Fly every aircraft for ``dt`` seconds (one or per aircraft) at constant bank,
    integrating the arc exactly."""
    rate = turn_rate(state.bank_rad)
    new_heading = state.heading_rad + rate * dt
    dx, dy = _arc(state.heading_rad, new_heading, rate, dt)
    return AircraftState(
        x_m=state.x_m + dx,
        y_m=state.y_m + dy,
        heading_rad=wrap_angle(new_heading),
        bank_steps=np.array(state.bank_steps, copy=True),
    )


def constant_bank_track(state: AircraftState, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (x, y), each (..., steps), after each of ``steps`` calls of :func:`propagate`.

    The same floats as stepping, bit for bit: only the heading is stepped one decision at a
    time (its wrap is sequential); the arcs are then computed for all steps at once and
    summed in order (a cumulative sum adds exactly as repeated ``x + dx`` does).
    """
    rate = turn_rate(state.bank_rad)
    before, after = [], []
    heading = np.asarray(state.heading_rad, dtype=np.float64)
    for _ in range(steps):
        new_heading = heading + rate * DECISION_PERIOD_S
        before.append(heading)
        after.append(new_heading)
        heading = wrap_angle(new_heading)
    dx, dy = _arc(
        np.stack(before, axis=-1), np.stack(after, axis=-1), rate[..., None], DECISION_PERIOD_S
    )
    x = np.cumsum(np.concatenate([np.asarray(state.x_m)[..., None], dx], axis=-1), axis=-1)
    y = np.cumsum(np.concatenate([np.asarray(state.y_m)[..., None], dy], axis=-1), axis=-1)
    return x[..., 1:], y[..., 1:]


def step(state: AircraftState, action: np.ndarray) -> AircraftState:
    """One decision: apply the bank action, then fly one decision period."""
    banked = state._replace(bank_steps=apply_action(state.bank_steps, action))
    return propagate(banked)


def start_poses(
    rng: np.random.Generator,
    n_aircraft: int,
    fire_centre_m: tuple[float, float] | np.ndarray,
    min_range_m: float = 150.0,
    max_range_m: float = 300.0,
) -> AircraftState:
    """Start poses: uniform range and bearing around the fire, uniform heading.

    ``fire_centre_m`` is one (x, y) or one per aircraft, (N, 2) (several fires: each
    aircraft around its own). Draws, per aircraft, range then bearing then heading from
    ``rng``; bank is 0.
    """
    draws = rng.random((n_aircraft, 3))
    distance = min_range_m + (max_range_m - min_range_m) * draws[:, 0]
    bearing = 2.0 * np.pi * draws[:, 1]
    centre = np.asarray(fire_centre_m, dtype=np.float64)
    return AircraftState(
        x_m=centre[..., 0] + distance * np.cos(bearing),
        y_m=centre[..., 1] + distance * np.sin(bearing),
        heading_rad=wrap_angle(2.0 * np.pi * draws[:, 2]),
        bank_steps=np.zeros(n_aircraft, dtype=np.int64),
    )


__all__ = [
    "ACTION_BANK_DELTA",
    "BANK_STEP_RAD",
    "DECISION_PERIOD_S",
    "GRAVITY_MPS2",
    "MAX_BANK_STEPS",
    "NUM_ACTIONS",
    "SPEED_MPS",
    "AircraftState",
    "apply_action",
    "constant_bank_track",
    "propagate",
    "start_poses",
    "step",
    "turn_rate",
    "wrap_angle",
]
