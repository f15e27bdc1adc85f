"""Pairwise relative states: how the ownship sees one other aircraft (docs/model.md, Q-network).

For ownship i and other aircraft j the state is ``(phi0, rho, theta, psi, phi1)``: own bank,
range, bearing of j relative to i's heading, j's heading relative to i's heading, j's bank.
Angles are wrapped to (-pi, pi]; counter-clockwise (left) is positive.

The network sees them normalised (``normalise``): banks / 50 deg, range / 1000 m clipped to
[0, 3], angles / pi, so every input lies in about [-1, 3]. An aircraft flying alone is given
one "far away" pseudo-intruder: 3 km directly behind it, on the same heading, wings level
(``ALONE_STATE``), which is how the network sees an aircraft at or beyond its range cap.

Each ownship sees at most :data:`NEAREST_PEERS` others: in a larger fleet, the nearest ones
(ties to the lower index), listed in increasing index order. So a decision's pairwise
Q-sum, and the receding-horizon planner's coordination, cost O(k) whatever the fleet's
size; fleets of up to k + 1 aircraft (the paper's) see every peer, exactly as before.
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


NEAREST_PEERS = 8
"""Peers an ownship's pairwise states (and its planner) consider: its k nearest."""


def peer_count(num_aircraft: int) -> int:
    """K, the pairs each ownship sees: ``max(min(N - 1, NEAREST_PEERS), 1)``."""
    return max(min(num_aircraft - 1, NEAREST_PEERS), 1)


def nearest_others(state: AircraftState) -> np.ndarray:
    """(..., N, K) indices of the peers each ownship sees (see the module docstring), from
    (..., N) poses; :func:`other_indices` broadcast when the fleet is small."""
    n = state.x_m.shape[-1]
    others = other_indices(n)
    if n - 1 <= NEAREST_PEERS:
        return np.broadcast_to(others, (*state.x_m.shape[:-1], *others.shape))
    dx = state.x_m[..., None, :] - state.x_m[..., :, None]
    dy = state.y_m[..., None, :] - state.y_m[..., :, None]
    distance = np.hypot(dx, dy)
    distance[..., np.arange(n), np.arange(n)] = np.inf  # never oneself
    nearest = np.argsort(distance, axis=-1, kind="stable")[..., :NEAREST_PEERS]
    return np.sort(nearest, axis=-1)


def other_indices(num_aircraft: int) -> np.ndarray:
    """(N, K) indices of the other aircraft of each ownship, in increasing order."""
    if num_aircraft == 1:
        return np.zeros((1, 0), dtype=np.int64)
    index = np.arange(num_aircraft)
    return np.array([np.delete(index, i) for i in index], dtype=np.int64)


def pairwise_states(state: AircraftState) -> np.ndarray:
    """Raw pairwise states, (..., N, K, 5) with K = :func:`peer_count`, from (..., N) poses."""
    num_aircraft = state.x_m.shape[-1]
    bank = state.bank_rad
    if num_aircraft == 1:
        alone = np.broadcast_to(ALONE_STATE, (*state.x_m.shape, 1, STATE_SIZE)).copy()
        alone[..., 0, 0] = bank
        return alone
    if num_aircraft - 1 <= NEAREST_PEERS:
        others = other_indices(num_aircraft)  # (N, K)

        def peer(field: np.ndarray) -> np.ndarray:
            return field[..., others]
    else:
        chosen = nearest_others(state)  # (..., N, K), per ownship
        flat = chosen.reshape(*chosen.shape[:-2], -1)

        def peer(field: np.ndarray) -> np.ndarray:
            return np.take_along_axis(field, flat, axis=-1).reshape(chosen.shape)

    dx = peer(state.x_m) - state.x_m[..., :, None]
    dy = peer(state.y_m) - state.y_m[..., :, None]
    own_heading = state.heading_rad[..., :, None]
    return np.stack(
        [
            np.broadcast_to(bank[..., :, None], dx.shape),
            np.hypot(dx, dy),
            wrap_angle(np.arctan2(dy, dx) - own_heading),
            wrap_angle(peer(state.heading_rad) - own_heading),
            peer(bank),
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
    "NEAREST_PEERS",
    "RANGE_SCALE_M",
    "STATE_SIZE",
    "nearest_others",
    "normalise",
    "other_indices",
    "pairwise_states",
    "peer_count",
]
