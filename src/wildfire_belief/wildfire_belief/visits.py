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

from wildfire_sim.grid import CELL_SIZE_M, PAPER_MAP, MapGeometry

VISIT_RADIUS_M = 100.0
"""Cells whose centre is this close to an aircraft are visited."""
WINDOW_HALF = 10
"""Cells from the aircraft's cell to the window edge."""
VISIT_WINDOW = 2 * WINDOW_HALF + 1
"""Edge of the visit window in cells."""
SCRATCH_CELLS = 1 << 22
"""Batches of at most this many map cells deduplicate visits in a scratch array indexed by
cell (O(visits) and fastest); larger ones (field maps) sort the visits instead, so that a
decision never costs a pass over the map."""


class VisitWindows(NamedTuple):
    """Visit windows of a batch of aircraft (leading dims of the poses, e.g. (E, N))."""

    row0: np.ndarray
    """Row of the window's southern edge (may be outside the map), int64."""
    col0: np.ndarray
    """Column of the window's western edge (may be outside the map), int64."""
    visited: np.ndarray
    """(..., 21, 21) bool: cell visited (centre within 100 m and inside the map)."""


class DiscWindow(NamedTuple):
    """A square window of cells centred on each aircraft's cell, and the disc in it."""

    row0: np.ndarray
    """Row of the window's southern edge (may be outside the map), int64."""
    col0: np.ndarray
    """Column of the window's western edge (may be outside the map), int64."""
    dx: np.ndarray
    """(..., side): east offset (m) of each window column's cell centres from the aircraft."""
    dy: np.ndarray
    """(..., side): north offset (m) of each window row's cell centres from the aircraft."""
    disc: np.ndarray
    """(..., side, side) bool: cell centre within the radius and the cell inside the map."""


def cell_offset_m(cells: np.ndarray, position_m: np.ndarray) -> np.ndarray:
    """Offset (m) of the centres of cells (row or column indices) from a position along the
    same axis: the one formula of every window's ``dx`` and ``dy``, so that a footprint
    computed run by run (``wildfire_agent.camera``) compares the very same floats."""
    return (cells + 0.5) * CELL_SIZE_M - position_m


def within_radius(dy: np.ndarray, dx: np.ndarray, radius_m: float) -> np.ndarray:
    """Whether offsets (dy, dx) lie within ``radius_m`` (broadcast): the disc's rule."""
    return dy**2 + dx**2 <= radius_m**2


def disc_window(
    x_m: np.ndarray,
    y_m: np.ndarray,
    half: int,
    radius_m: float,
    geometry: MapGeometry = PAPER_MAP,
) -> DiscWindow:
    """The ``2 half + 1`` cells square window around aircraft at (x, y) (any matching
    shapes), with the cells whose centre lies within ``radius_m``, inside the map. (The
    visits use 10 cells and 100 m; the cameras' range 30 cells and 300 m.)"""
    x_m, y_m = np.asarray(x_m, dtype=np.float64), np.asarray(y_m, dtype=np.float64)
    offsets = np.arange(-half, half + 1)
    row = np.floor(y_m / CELL_SIZE_M).astype(np.int64)
    col = np.floor(x_m / CELL_SIZE_M).astype(np.int64)
    rows = row[..., None] + offsets  # (..., side)
    cols = col[..., None] + offsets
    dy = cell_offset_m(rows, y_m[..., None])
    dx = cell_offset_m(cols, x_m[..., None])
    within = within_radius(dy[..., :, None], dx[..., None, :], radius_m)
    row_inside = (rows >= 0) & (rows < geometry.rows)
    col_inside = (cols >= 0) & (cols < geometry.cols)
    disc = within & row_inside[..., :, None] & col_inside[..., None, :]
    return DiscWindow(row - half, col - half, dx, dy, disc)


def visit_windows(
    x_m: np.ndarray, y_m: np.ndarray, geometry: MapGeometry = PAPER_MAP
) -> VisitWindows:
    """The visit windows of aircraft at (x, y) (any matching shapes) on the map ``geometry``."""
    window = disc_window(x_m, y_m, WINDOW_HALF, VISIT_RADIUS_M, geometry)
    return VisitWindows(row0=window.row0, col0=window.col0, visited=window.disc)


def visited_cells(
    windows: VisitWindows, geometry: MapGeometry = PAPER_MAP
) -> tuple[np.ndarray, np.ndarray]:
    """Cells visited by any aircraft of each environment, counted once.

    ``windows`` has leading dims (E, N). Returns ``(env, cell)`` int64 arrays with the flat
    cell index ``row * cols + col``, no duplicates, in no particular order.
    """
    num_envs, num_aircraft = windows.visited.shape[:2]
    flat_window = np.flatnonzero(windows.visited)
    pose, offset = np.divmod(flat_window, VISIT_WINDOW * VISIT_WINDOW)
    i, j = np.divmod(offset, VISIT_WINDOW)
    env = pose // num_aircraft
    cells_per_env = geometry.cells
    key = env * cells_per_env + (windows.row0.reshape(-1)[pose] + i) * geometry.cols
    key += windows.col0.reshape(-1)[pose] + j
    if num_envs * cells_per_env > SCRATCH_CELLS:
        key = np.unique(key)
        return key // cells_per_env, key % cells_per_env
    # Deduplicate in O(visits): every occurrence stamps its position into a scratch array
    # indexed by cell; the occurrence whose stamp survived is the one kept. (np.unique sorts
    # or hashes, and was the slowest part of a decision.)
    stamp = np.empty(num_envs * cells_per_env, dtype=np.int64)
    position = np.arange(key.size)
    stamp[key] = position
    key = key[stamp[key] == position]
    return key // cells_per_env, key % cells_per_env


def window_cells(grid: np.ndarray, row0: np.ndarray, col0: np.ndarray, side: int) -> np.ndarray:
    """Values of a (E, H, W) grid in square windows of ``side`` cells whose south-west cells
    are (row0, col0), each (E, N): (E, N, side, side); 0 outside the map."""
    height, width = grid.shape[-2:]
    span = np.arange(side)
    rows = row0[..., None] + span  # (E, N, side)
    cols = col0[..., None] + span
    inside = ((rows >= 0) & (rows < height))[..., :, None]
    inside = inside & ((cols >= 0) & (cols < width))[..., None, :]
    env = np.arange(grid.shape[0])[:, None, None, None]
    values = grid[
        env,
        np.clip(rows, 0, height - 1)[..., :, None],
        np.clip(cols, 0, width - 1)[..., None, :],
    ]
    return np.where(inside, values, 0).astype(grid.dtype)


def window_values(grid: np.ndarray, windows: VisitWindows) -> np.ndarray:
    """Values of a (E, H, W) grid in each visit window, (E, N, 21, 21); 0 where not visited."""
    values = window_cells(grid, windows.row0, windows.col0, VISIT_WINDOW)
    return np.where(windows.visited, values, 0).astype(grid.dtype)


__all__ = [
    "VISIT_RADIUS_M",
    "VISIT_WINDOW",
    "WINDOW_HALF",
    "DiscWindow",
    "VisitWindows",
    "cell_offset_m",
    "disc_window",
    "visit_windows",
    "visited_cells",
    "window_cells",
    "window_values",
    "within_radius",
]
