"""The camera footprints' run ends as a compiled loop (numba), for
:func:`wildfire_agent.camera.camera_windows`.

Per pose, camera and window row, a footprint is one run of columns, whose ends are found by
four monotone searches (the edge lines' lower and upper bounds, and the 300 m disc from
either side), then cut by the map. As whole-array numpy each search step was a pass over
every (pose, camera, row); here each entry steps on its own. The comparisons are the
per-cell rule's, float for float (``visits.cell_offset_m`` and ``visits.within_radius``:
one add, one multiply and one subtract per offset, squares as products, no transcendental
function), so the runs are the numpy ones exactly.

Every kernel that calls another lives in this one file: numba's disk cache (``cache=True``)
checks only the source file of the function it compiled.
"""

from __future__ import annotations

import math

import numba
import numpy as np

_kernel = numba.njit(cache=True, nogil=True, error_model="numpy")
_inlined = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

# The four searches of a row, each the smallest column at which its test holds.
_AT_LEAST_LOWER = 0  # dx >= lower (the edge lines' lower bound)
_ABOVE_UPPER = 1  # dx > upper (past the edge lines' upper bound)
_NEAR_START = 2  # dx >= 0 or within range (the disc, from the west)
_NEAR_STOP = 3  # dx > 0 and out of range (past the disc, to the east)


@_inlined
def _holds(
    test: int, j: int, bound: float, dy: float, x: float, col_west: int, cell: float, r: float
) -> bool:
    dx = (float(col_west + j) + 0.5) * cell - x  # visits.cell_offset_m
    if test == _AT_LEAST_LOWER:
        return dx >= bound
    if test == _ABOVE_UPPER:
        return dx > bound
    within = dy * dy + dx * dx <= r * r  # visits.within_radius
    if test == _NEAR_START:
        return dx >= 0.0 or within
    return dx > 0.0 and not within


@_inlined
def _first_true(
    test: int, bound: float, dy: float, x: float, col_west: int, side: int, cell: float, r: float
) -> int:
    # The search for one entry: the smallest column in [0, side] at which ``test``
    # holds, from the real-number column of dx = ``bound`` (the bound itself, or the disc's
    # edge), back while the column before holds, then forward while this one does not.
    guess = (bound + x) / cell - 0.5 - col_west
    j = int(min(max(np.ceil(guess), 0.0), float(side)))
    while j > 0 and _holds(test, j - 1, bound, dy, x, col_west, cell, r):
        j -= 1
    while j < side and not _holds(test, j, bound, dy, x, col_west, cell, r):
        j += 1
    return j


@_inlined
def _dx_bounds(
    east: np.ndarray, north: np.ndarray, down: np.ndarray, dy: float, altitude_m: float
) -> tuple[float, float]:
    # Side k of a camera holds where slope * dx + offset >= 0, with r = (dx, dy, -h): in a
    # row a bound on dx, from below where slope > 0 and from above where slope < 0. A side
    # parallel to the rows (slope 0) keeps all of the row or none of it.
    lower, upper = -np.inf, np.inf
    for k in range(east.size):
        slope = east[k]
        offset = north[k] * dy - altitude_m * down[k]
        if slope > 0.0:
            lower = max(lower, -offset / slope)
        elif slope < 0.0:
            upper = min(upper, -offset / slope)
        elif offset < 0.0:  # parallel and outside: the row is empty
            lower, upper = max(lower, np.inf), min(upper, -np.inf)
    return lower, upper


@_kernel
def footprint_runs(
    east: np.ndarray,
    north: np.ndarray,
    down: np.ndarray,
    dy: np.ndarray,
    rows: np.ndarray,
    x: np.ndarray,
    col_west: np.ndarray,
    map_rows: int,
    map_cols: int,
    cell: float,
    range_m: float,
    altitude_m: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Run ends ``first <= column < stop`` of every footprint row, (P, C, R) int64 each.

    ``east``, ``north`` and ``down`` (P, C, 4) are the components of camera C's four
    inward side normals at pose P (east and north turned by the heading); ``dy`` (P, R) is
    each window row's north offset from the aircraft and ``rows`` (P, R) its map row; ``x``
    (P,) is the aircraft's east position and ``col_west`` (P,) the map column of window
    column 0. A row off the map, or with no cell in range, is empty (``stop == first``).
    """
    poses, cameras = east.shape[0], east.shape[1]
    side = dy.shape[1]
    first = np.empty((poses, cameras, side), np.int64)
    stop = np.empty((poses, cameras, side), np.int64)
    for p in range(poses):
        west = col_west[p]
        xp = x[p]
        map_first = min(max(-west, 0), side)
        map_stop = min(max(map_cols - west, 0), side)
        for i in range(side):
            d = dy[p, i]
            usable = d * d + 0.0 <= range_m * range_m and 0 <= rows[p, i] < map_rows
            reach = math.sqrt(max(range_m * range_m - d * d, 0.0))
            # The disc's tests ignore the bound: +/-reach only starts their searches.
            near_start = _first_true(_NEAR_START, -reach, d, xp, west, side, cell, range_m)
            near_stop = _first_true(_NEAR_STOP, reach, d, xp, west, side, cell, range_m)
            for c in range(cameras):
                low, high = _dx_bounds(east[p, c], north[p, c], down[p, c], d, altitude_m)
                start = _first_true(_AT_LEAST_LOWER, low, d, xp, west, side, cell, range_m)
                end = _first_true(_ABOVE_UPPER, high, d, xp, west, side, cell, range_m)
                start = max(max(start, near_start), map_first)
                end = min(min(end, near_stop), map_stop)
                first[p, c, i] = start
                stop[p, c, i] = max(end, start) if usable else start
    return first, stop


def compile_kernels() -> None:
    """Compile (or load from the disk cache) every kernel of this module."""
    normals, one = np.ones((1, 1, 4)), np.zeros((1, 1))
    footprint_runs(
        normals,
        normals,
        normals,
        one,
        one.astype(np.int64),
        np.zeros(1),
        np.zeros(1, np.int64),
        1,
        1,
        1.0,
        1.0,
        1.0,
    )


__all__ = ["compile_kernels", "footprint_runs"]
