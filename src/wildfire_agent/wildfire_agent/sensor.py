"""The aircraft's fire sensor: a polar image relative to position and heading.

See docs/model.md, Sensor and the observation approach.

The image is ``(N_BEARINGS, N_RANGES) = (30, 40)``, indexed ``[bearing, range]``:

* bearing bin j samples the direction ``heading + BEARINGS_RAD[j]``, where
  ``BEARINGS_RAD[j] = -pi + (j + 0.5) * 2 pi / 30`` (counter-clockwise, i.e. to the left, is
  positive; bin 15 looks 6 degrees left of straight ahead, bin 14 6 degrees right);
* range bin i samples at ``RANGES_M[i] = 10 + 490 * (i / 39)**2`` metres: 10 m to 500 m,
  spacing growing linearly from 0.3 m near the aircraft to 25 m at the far edge, so the
  image resolves the fire finely close by and coarsely far away. (The paper's "intervals
  from 10 m to 100 m" cannot hold with 40 cut-points and a 500 m range; see docs/model.md.)

Each sample takes the burning value of the grid cell that contains it (the nearest cell
centre), 0 outside the map.
"""

from __future__ import annotations

import numpy as np

from wildfire_sim.grid import CELL_SIZE_M

N_BEARINGS = 30
N_RANGES = 40
MIN_RANGE_M = 10.0
MAX_RANGE_M = 500.0
BEARINGS_RAD = -np.pi + (np.arange(N_BEARINGS) + 0.5) * (2.0 * np.pi / N_BEARINGS)
"""Bearing of each image row relative to the heading (counter-clockwise positive)."""
RANGES_M = MIN_RANGE_M + (MAX_RANGE_M - MIN_RANGE_M) * (np.arange(N_RANGES) / (N_RANGES - 1)) ** 2
"""Range of each image column."""


_COS_BEARING = np.cos(BEARINGS_RAD)[:, None]
_SIN_BEARING = np.sin(BEARINGS_RAD)[:, None]


def sample_points(
    x_m: np.ndarray, y_m: np.ndarray, heading_rad: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Map-frame (x, y) of every sample, each shaped ``(*pose_shape, 30, 40)``."""
    cos_h = np.cos(heading_rad)[..., None, None]
    sin_h = np.sin(heading_rad)[..., None, None]
    # cos(h + b) = cos h cos b - sin h sin b, sin(h + b) = sin h cos b + cos h sin b.
    dx = (cos_h * _COS_BEARING - sin_h * _SIN_BEARING) * RANGES_M
    dy = (sin_h * _COS_BEARING + cos_h * _SIN_BEARING) * RANGES_M
    return np.asarray(x_m)[..., None, None] + dx, np.asarray(y_m)[..., None, None] + dy


def observe(
    burning: np.ndarray, x_m: np.ndarray, y_m: np.ndarray, heading_rad: np.ndarray
) -> np.ndarray:
    """Sensor images of a batch of aircraft.

    ``burning`` is (E, H, W) bool; poses are (E, N). Returns (E, N, 30, 40) uint8 in {0, 1}.
    For one map and one aircraft pass (1, H, W) and (1, 1)-shaped poses.
    """
    height, width = burning.shape[-2:]
    sx, sy = sample_points(x_m, y_m, heading_rad)
    col = np.floor(sx / CELL_SIZE_M).astype(np.intp)
    row = np.floor(sy / CELL_SIZE_M).astype(np.intp)
    inside = (row >= 0) & (row < height) & (col >= 0) & (col < width)
    np.clip(row, 0, height - 1, out=row)
    np.clip(col, 0, width - 1, out=col)
    # One flat gather (much faster than indexing with three arrays); pass a C-contiguous
    # ``burning`` to avoid a copy.
    env = np.arange(burning.shape[0]).reshape(-1, *([1] * (row.ndim - 1)))
    flat = (env * height + row) * width + col
    values = burning.reshape(-1)[flat]
    values &= inside
    return values.view(np.uint8)


__all__ = ["BEARINGS_RAD", "N_BEARINGS", "N_RANGES", "RANGES_M", "observe", "sample_points"]
