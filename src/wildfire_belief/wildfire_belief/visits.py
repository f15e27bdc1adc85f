"""Which cells an aircraft visits: every cell whose centre lies within 100 m.

See docs/model.md, Shared belief.

An aircraft's visits fit in a ``VISIT_WINDOW`` x ``VISIT_WINDOW`` (21 x 21) window of cells
centred on the cell it is in: a cell centre 11 cells away is at least 105 m off. The agent
node publishes exactly this window (as an OccupancyGrid), and the environment and the
belief aggregator turn windows into visited cells with the same functions below.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from wildfire_sim.grid import CELL_SIZE_M, GRID_SIZE

VISIT_RADIUS_M = 100.0
"""Cells whose centre is this close to an aircraft are visited."""
WINDOW_HALF = 10
"""Cells from the aircraft's cell to the window edge."""
VISIT_WINDOW = 2 * WINDOW_HALF + 1
"""Edge of the visit window in cells."""

_OFFSETS = np.arange(-WINDOW_HALF, WINDOW_HALF + 1)
_SPAN = np.arange(VISIT_WINDOW)


class VisitWindows(NamedTuple):
    """Visit windows of a batch of aircraft (leading dims of the poses, e.g. (E, N))."""

    row0: np.ndarray
    """Row of the window's southern edge (may be outside the map), int64."""
    col0: np.ndarray
    """Column of the window's western edge (may be outside the map), int64."""
    visited: np.ndarray
    """(..., 21, 21) bool: cell visited (centre within 100 m and inside the map)."""


def visit_windows(x_m: np.ndarray, y_m: np.ndarray) -> VisitWindows:
    """The visit windows of aircraft at (x, y) (any matching shapes)."""
    x_m, y_m = np.asarray(x_m, dtype=np.float64), np.asarray(y_m, dtype=np.float64)
    row = np.floor(y_m / CELL_SIZE_M).astype(np.int64)
    col = np.floor(x_m / CELL_SIZE_M).astype(np.int64)
    rows = row[..., None] + _OFFSETS  # (..., 21)
    cols = col[..., None] + _OFFSETS
    dy = (rows + 0.5) * CELL_SIZE_M - y_m[..., None]
    dx = (cols + 0.5) * CELL_SIZE_M - x_m[..., None]
    within = dy[..., :, None] ** 2 + dx[..., None, :] ** 2 <= VISIT_RADIUS_M**2
    row_inside = (rows >= 0) & (rows < GRID_SIZE)
    col_inside = (cols >= 0) & (cols < GRID_SIZE)
    visited = within & row_inside[..., :, None] & col_inside[..., None, :]
    return VisitWindows(row0=row - WINDOW_HALF, col0=col - WINDOW_HALF, visited=visited)


def visited_cells(windows: VisitWindows) -> tuple[np.ndarray, np.ndarray]:
    """Cells visited by any aircraft of each environment, counted once.

    ``windows`` has leading dims (E, N). Returns ``(env, cell)`` int64 arrays with the flat
    cell index ``row * GRID_SIZE + col``, no duplicates, in no particular order.
    """
    num_envs, num_aircraft = windows.visited.shape[:2]
    flat_window = np.flatnonzero(windows.visited)
    pose, offset = np.divmod(flat_window, VISIT_WINDOW * VISIT_WINDOW)
    i, j = np.divmod(offset, VISIT_WINDOW)
    env = pose // num_aircraft
    cells_per_env = GRID_SIZE * GRID_SIZE
    key = env * cells_per_env + (windows.row0.reshape(-1)[pose] + i) * GRID_SIZE
    key += windows.col0.reshape(-1)[pose] + j
    # Deduplicate in O(visits): every occurrence stamps its position into a scratch array
    # indexed by cell; the occurrence whose stamp survived is the one kept. (np.unique sorts
    # or hashes, and was the slowest part of a decision.)
    stamp = np.empty(num_envs * cells_per_env, dtype=np.int64)
    position = np.arange(key.size)
    stamp[key] = position
    key = key[stamp[key] == position]
    return key // cells_per_env, key % cells_per_env


def window_values(grid: np.ndarray, windows: VisitWindows) -> np.ndarray:
    """Values of a (E, H, W) grid in each visit window, (E, N, 21, 21); 0 outside the map."""
    # row0/col0 are the windows' south-west cells: the window spans row0 .. row0 + 20.
    rows = windows.row0[..., None] + _SPAN  # (E, N, 21)
    cols = windows.col0[..., None] + _SPAN
    env = np.arange(grid.shape[0])[:, None, None, None]
    values = grid[
        env,
        np.clip(rows, 0, GRID_SIZE - 1)[..., :, None],
        np.clip(cols, 0, GRID_SIZE - 1)[..., None, :],
    ]
    return np.where(windows.visited, values, 0).astype(grid.dtype)


__all__ = [
    "VISIT_RADIUS_M",
    "VISIT_WINDOW",
    "WINDOW_HALF",
    "VisitWindows",
    "visit_windows",
    "visited_cells",
    "window_values",
]
