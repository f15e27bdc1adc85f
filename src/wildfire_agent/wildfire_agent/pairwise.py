"""Pairwise relative states: how the ownship sees one other aircraft (docs/model.md, Q-network).

For ownship i and other aircraft j the state is ``(phi0, rho, theta, psi, phi1)``: own bank,
range, bearing of j relative to i's heading, j's heading relative to i's heading, j's bank.
Angles are wrapped to (-pi, pi]; counter-clockwise (left) is positive.

The network sees them normalised (``normalise``): banks / 50 deg, range / 1000 m clipped to
[0, 3], angles / pi, so every input lies in about [-1, 3]. An aircraft flying alone is given
one "far away" pseudo-intruder: 3 km directly behind it, on the same heading, wings level
(``ALONE_STATE``), which is how the network sees an aircraft at or beyond its range cap.
"""

from __future__ import annotations

import numpy as np

from wildfire_agent.dynamics import BANK_STEP_RAD, MAX_BANK_STEPS, AircraftState, wrap_angle

STATE_SIZE = 5
RANGE_SCALE_M = 1000.0
"""Range normalisation."""
MAX_RANGE_M = 3000.0
"""Ranges are clipped here before normalisation."""
ALONE_STATE = np.array([0.0, MAX_RANGE_M, np.pi, 0.0, 0.0])
"""Raw (phi0 = own bank, filled in per aircraft) state of the pseudo-intruder when alone."""


def other_indices(num_aircraft: int) -> np.ndarray:
    """(N, K) indices of the other aircraft of each ownship, in increasing order."""
    if num_aircraft == 1:
        return np.zeros((1, 0), dtype=np.int64)
    index = np.arange(num_aircraft)
    return np.array([np.delete(index, i) for i in index], dtype=np.int64)


def pairwise_states(state: AircraftState) -> np.ndarray:
    """Raw pairwise states, (..., N, K, 5) with K = max(N - 1, 1), from (..., N) poses."""
    num_aircraft = state.x_m.shape[-1]
    bank = state.bank_rad
    if num_aircraft == 1:
        alone = np.broadcast_to(ALONE_STATE, (*state.x_m.shape, 1, STATE_SIZE)).copy()
        alone[..., 0, 0] = bank
        return alone
    others = other_indices(num_aircraft)  # (N, K)
    dx = state.x_m[..., others] - state.x_m[..., :, None]
    dy = state.y_m[..., others] - state.y_m[..., :, None]
    own_heading = state.heading_rad[..., :, None]
    return np.stack(
        [
            np.broadcast_to(bank[..., :, None], dx.shape),
            np.hypot(dx, dy),
            wrap_angle(np.arctan2(dy, dx) - own_heading),
            wrap_angle(state.heading_rad[..., others] - own_heading),
            bank[..., others],
        ],
        axis=-1,
    )


def normalise(raw: np.ndarray) -> np.ndarray:
    """Network inputs from raw pairwise states, float32."""
    max_bank = MAX_BANK_STEPS * BANK_STEP_RAD
    scale = np.array([max_bank, RANGE_SCALE_M, np.pi, np.pi, max_bank])
    clipped = raw.copy()
    clipped[..., 1] = np.minimum(clipped[..., 1], MAX_RANGE_M)
    return (clipped / scale).astype(np.float32)


__all__ = [
    "ALONE_STATE",
    "MAX_RANGE_M",
    "RANGE_SCALE_M",
    "STATE_SIZE",
    "normalise",
    "other_indices",
    "pairwise_states",
]
