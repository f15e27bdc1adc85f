"""Compiled loops of the filtered belief's per-decision work (numba).

Each decision a batch of 64 camera episodes makes ~130 000 reports on a 640 000-cell belief.
Written as whole-array numpy, applying them scanned the whole belief several times (a dense
count per cell, then a search for the counted cells); these loops touch the reports and
their cells only. They are the same arithmetic, operation for operation, as the numpy they
replaced (integer counts, one multiply, one add and a clip per cell: no transcendental
function, whose compiled and numpy versions differ in the last bit), so every belief is
bit-identical to before.

Every kernel here is self-contained: numba's disk cache (``cache=True``) checks only the
source file of the function it compiled.
"""

from __future__ import annotations

import numba
import numpy as np

kernel = numba.njit(cache=True, nogil=True, error_model="numpy")


@kernel
def apply_reports(
    log_odds: np.ndarray,
    last_report: np.ndarray,
    now: np.ndarray,
    env: np.ndarray,
    flat: np.ndarray,
    burning: np.ndarray,
    weight: float,
    certain: bool,
    bound: float,
    net: np.ndarray,
) -> None:
    """Add every report to its cell's log-odds, then clip each touched cell once; stamp
    each reported cell with its environment's tick ``now[env]`` in ``last_report``.

    ``log_odds``, ``last_report`` and ``net`` are flat views of one size (``net`` all zero,
    and left so); ``env``, ``flat`` and ``burning`` give each report's environment, cell
    and value. A cell moves by its net
    count (reports "burning" minus reports "not burning") times ``weight``, or, when reports
    are ``certain``, by ``2 * bound`` toward its majority (no move on a tie).
    """
    for r in range(flat.size):
        net[flat[r]] += 1 if burning[r] else -1
        last_report[flat[r]] = now[env[r]]
    for r in range(flat.size):
        cell = flat[r]
        count = net[cell]
        if count == 0:  # cancelled out, or this cell was already applied
            continue
        net[cell] = 0
        # Certain reports: the majority moves the cell by two bounds (then clipped).
        sign = 1.0 if count > 0 else -1.0
        step = sign * (2.0 * bound) if certain else float(count) * weight
        log_odds[cell] = min(max(log_odds[cell] + step, -bound), bound)


@kernel
def run_cells(
    first: np.ndarray, stop: np.ndarray, lead_shape: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every seen cell of runs ``first <= column < stop`` ((M, rows) int64 each: M
    footprints, the C-order flattening of ``lead_shape``), in C order of (footprint, row),
    then by column. Returns each cell's footprint index, one row per dim of ``lead_shape``
    ((len(lead_shape), cells): counted up as the loop goes, not divided out), its row and
    its column."""
    total = 0
    for m in range(first.shape[0]):
        for i in range(first.shape[1]):
            total += max(stop[m, i] - first[m, i], 0)
    dims = lead_shape.size
    lead = np.empty((dims, total), np.int64)
    row = np.empty(total, np.int64)
    column = np.empty(total, np.int64)
    index = np.zeros(dims, np.int64)
    k = 0
    for m in range(first.shape[0]):
        for i in range(first.shape[1]):
            for j in range(first[m, i], stop[m, i]):
                for d in range(dims):
                    lead[d, k] = index[d]
                row[k], column[k] = i, j
                k += 1
        # The next footprint's multi-index: the last dim counts fastest (C order).
        d = dims - 1
        if d >= 0:
            index[d] += 1
        while d > 0 and index[d] == lead_shape[d]:
            index[d] = 0
            d -= 1
            index[d] += 1
    return lead, row, column


def compile_kernels() -> None:
    """Compile (or load from the disk cache) every kernel of this module."""
    net, one = np.zeros(1, np.int32), np.zeros(1, np.int64)
    apply_reports(np.zeros(1), one.copy(), one, one, one, np.ones(1, bool), 1.0, False, 1.0, net)
    run_cells(np.zeros((1, 1), np.int64), np.ones((1, 1), np.int64), np.ones(1, np.int64))


__all__ = ["apply_reports", "compile_kernels", "run_cells"]
