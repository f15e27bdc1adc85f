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


@kernel
def window_reports(
    first: np.ndarray,
    stop: np.ndarray,
    row0: np.ndarray,
    col0: np.ndarray,
    episode: np.ndarray,
    truth: np.ndarray,
    uniforms: np.ndarray,
    p: float,
    cols: int,
    cells: int,
    codes: np.ndarray,
    clear_code: int,
    burning_code: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The noisy reports of a batch of aircraft's sensor windows, in ``run_cells`` order.

    ``first`` and ``stop`` (A, K, rows) are the runs of each aircraft's K sensors; ``row0``,
    ``col0`` and ``episode`` (A,) its windows' origin and its episode; ``truth`` the flat
    (E * cells) bool map (``cols`` cells a row) of every episode; ``uniforms`` one per seen cell, in
    ``run_cells`` order (each aircraft's block, ``camera.report_uniforms``). A report flips
    its cell's truth when its uniform is below ``p``. Returns each report's episode, flat
    map cell, value and whether it flipped. Where ``codes`` has A rows, ((A, K, rows, side)
    uint8, all ``NOTHING``), each report's code is written at its place in its window.
    """
    aircraft, sensors, rows = first.shape
    total = 0
    for a in range(aircraft):
        for k in range(sensors):
            for i in range(rows):
                total += max(stop[a, k, i] - first[a, k, i], 0)
    env = np.empty(total, np.int64)
    cell = np.empty(total, np.int64)
    value = np.empty(total, np.bool_)
    wrong = np.empty(total, np.bool_)
    n = 0
    for a in range(aircraft):
        e = episode[a]
        for k in range(sensors):
            for i in range(rows):
                row_start = e * cells + (row0[a] + i) * cols + col0[a]
                for j in range(first[a, k, i], stop[a, k, i]):
                    flat = row_start + j
                    flipped = uniforms[n] < p
                    seen = truth[flat] != flipped
                    env[n], cell[n] = e, flat - e * cells
                    value[n], wrong[n] = seen, flipped
                    if codes.shape[0]:
                        codes[a, k, i, j] = burning_code if seen else clear_code
                    n += 1
    return env, cell, value, wrong


@kernel
def score_cells(
    before: np.ndarray,
    after: np.ndarray,
    truth: np.ndarray,
    scored: np.ndarray,
    scores: np.ndarray,
    alarms: np.ndarray,
) -> None:
    """The score under noise of one decision (``filtered_aggregator.score_decision``).

    ``before``, ``after``, ``truth`` and ``scored`` are flat bool views of E episodes'
    maps, one after the other; ``scores`` and ``alarms`` (E,) int64 receive each episode's
    count, and ``scored`` the cells that scored.
    """
    per_episode = before.size // scores.size
    for e in range(scores.size):
        score, alarm = 0, 0
        for k in range(e * per_episode, (e + 1) * per_episode):
            if after[k] and not before[k]:  # turned believed burning
                if not truth[k]:
                    alarm += 1
                elif not scored[k]:
                    scored[k] = True
                    score += 1
        scores[e], alarms[e] = score, alarm


@kernel
def stencil_sum(values: np.ndarray, weights: np.ndarray, out: np.ndarray) -> None:
    """``out[e, r, c] = sum_{(i, j) != centre} weights[e, i, j] * values[e, r + i - h,
    c + j - h]`` over the (2h + 1)^2 stencil, 0 beyond the map edge: one product and one
    add per offset, the offsets in row-major order from 0 (the numpy sum's order)."""
    episodes, height, width = values.shape
    side = weights.shape[1]
    half = side // 2
    for e in range(episodes):
        for r in range(height):
            for c in range(width):
                total = 0.0
                for i in range(side):
                    row = r + i - half
                    for j in range(side):
                        col = c + j - half
                        if i == half and j == half:
                            continue
                        # Beyond the edge the numpy sum added weight * 0.0: adding +0.0
                        # leaves a sum unchanged (a -0.0 sum would turn +0.0; none is).
                        if 0 <= row < height and 0 <= col < width:
                            total += weights[e, i, j] * values[e, row, col]
                out[e, r, c] = total


def compile_kernels() -> None:
    """Compile (or load from the disk cache) every kernel of this module."""
    net, one = np.zeros(1, np.int32), np.zeros(1, np.int64)
    apply_reports(np.zeros(1), one.copy(), one, one, one, np.ones(1, bool), 1.0, False, 1.0, net)
    run_cells(np.zeros((1, 1), np.int64), np.ones((1, 1), np.int64), np.ones(1, np.int64))
    runs, origin = np.zeros((1, 1, 1), np.int64), np.zeros(1, np.int64)
    codes = np.zeros((0, 1, 1, 1), np.uint8)
    window_reports(
        runs,
        runs + 1,
        origin,
        origin,
        origin,
        np.zeros(1, bool),
        np.ones(1),
        0.1,
        1,
        1,
        codes,
        1,
        2,
    )
    stencil_sum(np.zeros((1, 1, 1)), np.zeros((1, 5, 5)), np.zeros((1, 1, 1)))
    cells, counts = np.zeros(1, bool), np.zeros(1, np.int64)
    score_cells(cells, cells, cells, cells.copy(), counts, counts.copy())


__all__ = [
    "apply_reports",
    "compile_kernels",
    "run_cells",
    "score_cells",
    "stencil_sum",
    "window_reports",
]
