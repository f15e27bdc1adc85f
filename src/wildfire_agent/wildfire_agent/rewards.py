"""Rewards of the observation-based approach (SPEC 2.3) and the proximity penalty.

Per aircraft and decision, with the weights of :class:`ObservationRewardWeights`:

* ``r1 = -lambda1 * d_fire``: distance from the aircraft to the nearest burning cell centre,
  capped at the sensor range (500 m), so r1 is in [-1, 0];
* ``r2 = -lambda2 * n_clear``: number of non-burning map cells whose centre lies within
  r0 = 50 m of the aircraft (at most 81), so r2 is in [-1, 0]: fly over the fire front;
* ``r3 = -lambda3 * phi^2``: at most 0.38 at the 50 degree limit: fly smoothly;
* ``r4 = -lambda4 * sum_j exp(-rho_j / c)``: c = 100 m, 1 per aircraft on top of you.

``d_fire`` and ``n_clear`` are read from per-cell look-up maps computed once per fire step
(a Euclidean distance transform and a disc count), at the cell the aircraft is over, so the
receding-horizon planner can score thousands of hypothetical positions at the same cost as
the environment scores one. Off the map, ``d_fire`` is measured to the nearest map cell and
the distance outside is added (still capped); ``n_clear`` counts map cells only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.ndimage
import torch
import torch.nn.functional as F

from wildfire_sim.grid import CELL_SIZE_M, GRID_SIZE


@dataclass(frozen=True)
class ObservationRewardWeights:
    """Weights of the observation-based reward (lambda_1..lambda_4, r0, c)."""

    distance: float = 1.0 / 500.0
    """lambda_1, per metre to the nearest burning cell."""
    clear_cells: float = 1.0 / 81.0
    """lambda_2, per non-burning cell within ``clear_radius_m``."""
    bank: float = 0.5
    """lambda_3, per squared radian of bank."""
    proximity: float = 1.0
    """lambda_4, per unit of exp(-range / proximity_scale_m) to each other aircraft."""
    clear_radius_m: float = 50.0
    """r0."""
    proximity_scale_m: float = 100.0
    """c."""
    max_distance_m: float = 500.0
    """Cap of the distance term (the sensor range)."""


class FireFieldMaps(NamedTuple):
    """Per-cell look-up maps of one fire state, batched: (E, H, W) and padded (E, H', W')."""

    distance_m: np.ndarray
    """Distance from each cell centre to the nearest burning cell centre (capped), float32."""
    clear_count: np.ndarray
    """Non-burning map cells within r0 of each cell centre, padded by ``pad`` cells, float32."""
    pad: int
    """Margin (cells) of ``clear_count`` around the map."""


def disc_offsets_kernel(radius_m: float) -> np.ndarray:
    """Square 0/1 kernel of the cells whose centre is within ``radius_m`` of the centre cell."""
    half = int(np.floor(radius_m / CELL_SIZE_M))
    offsets = np.arange(-half, half + 1) * CELL_SIZE_M
    return (offsets[:, None] ** 2 + offsets[None, :] ** 2 <= radius_m**2).astype(np.float32)


def fire_field_maps(
    burning: np.ndarray, weights: ObservationRewardWeights | None = None
) -> FireFieldMaps:
    """Look-up maps of (E, H, W) burning grids."""
    weights = weights or ObservationRewardWeights()
    num_envs = burning.shape[0]
    distance = np.full(burning.shape, weights.max_distance_m, dtype=np.float32)
    for env in range(num_envs):
        if burning[env].any():
            edt = scipy.ndimage.distance_transform_edt(~burning[env]) * CELL_SIZE_M
            distance[env] = np.minimum(edt, weights.max_distance_m)
    kernel = disc_offsets_kernel(weights.clear_radius_m)
    pad = kernel.shape[0] // 2
    clear = np.pad(~burning, ((0, 0), (pad, pad), (pad, pad))).astype(np.float32)
    # Counts are small integers: exact in float32 whatever the convolution's order.
    counts = F.conv2d(torch.from_numpy(clear)[:, None], torch.from_numpy(kernel)[None, None],
                      padding=pad)
    return FireFieldMaps(distance_m=distance, clear_count=counts[:, 0].numpy(), pad=pad)


def fire_terms(
    maps: FireFieldMaps,
    env: np.ndarray,
    x_m: np.ndarray,
    y_m: np.ndarray,
    weights: ObservationRewardWeights | None = None,
) -> np.ndarray:
    """``r1 + r2`` at positions (x, y) in environments ``env`` (all the same shape)."""
    weights = weights or ObservationRewardWeights()
    col = np.floor(x_m / CELL_SIZE_M).astype(np.int64)
    row = np.floor(y_m / CELL_SIZE_M).astype(np.int64)
    inside_col = np.clip(col, 0, GRID_SIZE - 1)
    inside_row = np.clip(row, 0, GRID_SIZE - 1)
    # Off the map: add how far outside the map the aircraft is.
    outside = np.hypot(
        np.maximum(np.maximum(-x_m, x_m - GRID_SIZE * CELL_SIZE_M), 0.0),
        np.maximum(np.maximum(-y_m, y_m - GRID_SIZE * CELL_SIZE_M), 0.0),
    )
    distance = np.minimum(
        maps.distance_m[env, inside_row, inside_col] + outside, weights.max_distance_m
    )
    pad = maps.pad
    padded_size = maps.clear_count.shape[-1]
    in_pad = (row >= -pad) & (row < GRID_SIZE + pad) & (col >= -pad) & (col < GRID_SIZE + pad)
    clear = np.where(
        in_pad,
        maps.clear_count[
            env, np.clip(row + pad, 0, padded_size - 1), np.clip(col + pad, 0, padded_size - 1)
        ],
        0.0,
    )
    return -weights.distance * distance - weights.clear_cells * clear


def proximity_sum(x_m: np.ndarray, y_m: np.ndarray, scale_m: float) -> np.ndarray:
    """``sum_j exp(-rho_ij / c)`` over the other aircraft j, for (..., N) positions."""
    dx = x_m[..., :, None] - x_m[..., None, :]
    dy = y_m[..., :, None] - y_m[..., None, :]
    closeness = np.exp(-np.hypot(dx, dy) / scale_m)
    num_aircraft = x_m.shape[-1]
    closeness[..., np.arange(num_aircraft), np.arange(num_aircraft)] = 0.0
    return closeness.sum(axis=-1)


def observation_rewards(
    maps: FireFieldMaps,
    x_m: np.ndarray,
    y_m: np.ndarray,
    bank_rad: np.ndarray,
    weights: ObservationRewardWeights | None = None,
) -> np.ndarray:
    """Observation-based reward of every aircraft, (E, N) float64 from (E, N) poses."""
    weights = weights or ObservationRewardWeights()
    env = np.broadcast_to(np.arange(x_m.shape[0])[:, None], x_m.shape)
    return (
        fire_terms(maps, env, x_m, y_m, weights)
        - weights.bank * bank_rad**2
        - weights.proximity * proximity_sum(x_m, y_m, weights.proximity_scale_m)
    )


__all__ = [
    "FireFieldMaps",
    "ObservationRewardWeights",
    "disc_offsets_kernel",
    "fire_field_maps",
    "fire_terms",
    "observation_rewards",
    "proximity_sum",
]
