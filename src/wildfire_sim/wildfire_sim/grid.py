"""Geometry of the square map shared by the fire, the aircraft sensors and the belief.

Map frame: x east, y north, metres, origin at the south-west corner. Arrays are indexed
``[row, col]`` with row 0 at the south, exactly as ``nav_msgs/OccupancyGrid`` stores them,
so cell (r, c) has its centre at ((c + 0.5) * CELL_SIZE_M, (r + 0.5) * CELL_SIZE_M).
"""

from __future__ import annotations

import numpy as np

# The map's cells are the wire contract's: the simulator and the messages share one layout.
from wildfire_msgs_py.contract import CELL_SIZE_M, GRID_SIZE

MAP_SIZE_M = GRID_SIZE * CELL_SIZE_M
"""Edge length of the map in metres (1 km)."""


def cell_centres_m(n: int = GRID_SIZE) -> np.ndarray:
    """Centre coordinate in metres of each of ``n`` cells along one axis."""
    return (np.arange(n, dtype=np.float64) + 0.5) * CELL_SIZE_M


def cell_of(x_m: np.ndarray, y_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column (int64, possibly outside the map) of the cell containing (x, y)."""
    col = np.floor(np.asarray(x_m) / CELL_SIZE_M).astype(np.int64)
    row = np.floor(np.asarray(y_m) / CELL_SIZE_M).astype(np.int64)
    return row, col


def inside_map(row: np.ndarray, col: np.ndarray, n: int = GRID_SIZE) -> np.ndarray:
    """True where (row, col) is a cell of the map."""
    return (row >= 0) & (row < n) & (col >= 0) & (col < n)


__all__ = ["CELL_SIZE_M", "GRID_SIZE", "MAP_SIZE_M", "cell_centres_m", "cell_of", "inside_map"]
