"""Compiled kernels of the clairvoyant bound ``oracle`` (``wildfire_learning.oracle``):
the project's dynamics float for float, the visit test of ``wildfire_belief.visits``
operation for operation, and the coordinate-descent search of one aircraft's plan.

Every compiled function that calls another lives in this one file: numba's disk cache
(``cache=True``) checks only the source file of the function it compiled, so a kernel
calling one from another file could run a stale cached copy after that file changes.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from wildfire_agent.dynamics import (
    BANK_STEP_RAD,
    DECISION_PERIOD_S,
    MAX_BANK_STEPS,
    SPEED_MPS,
    turn_rate,
)
from wildfire_belief.visits import VISIT_RADIUS_M, WINDOW_HALF
from wildfire_sim.episode import DECISIONS_PER_FIRE_STEP
from wildfire_sim.grid import CELL_SIZE_M

NEVER = np.iinfo(np.int64).max // 4
"""A fire step or decision that never comes."""

kernel = numba.njit(cache=True, nogil=True, error_model="numpy")
inlined = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

_RADIUS2 = VISIT_RADIUS_M**2
RATES = np.ascontiguousarray(
    turn_rate(np.arange(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1) * BANK_STEP_RAD), np.float64
)
"""Turn rate per bank level (row ``bank_steps + 10``), from numpy's tan as ``dynamics``."""


@inlined
def fly_one(
    x: float, y: float, heading: float, level: int, action: int, rates: np.ndarray
) -> tuple[float, float, float, int]:
    """``dynamics.step`` of one aircraft, float for float: bank action, then 0.1 s of arc."""
    proposed = level + (1 if action == 1 else -1)
    if abs(proposed) <= MAX_BANK_STEPS:
        level = proposed
    turn = rates[level + MAX_BANK_STEPS]
    new_heading = heading + turn * DECISION_PERIOD_S
    if turn != 0.0:
        radius = SPEED_MPS / turn
        x = x + radius * (math.sin(new_heading) - math.sin(heading))
        y = y + radius * (math.cos(heading) - math.cos(new_heading))
    else:
        x = x + SPEED_MPS * DECISION_PERIOD_S * math.cos(heading)
        y = y + SPEED_MPS * DECISION_PERIOD_S * math.sin(heading)
    # ``wrap_angle``: Python's float modulo, as numpy's (the remainder takes the divisor's sign).
    heading = np.pi - (np.pi - new_heading) % (2.0 * np.pi)
    return x, y, heading, level


@kernel
def fly_path(
    x: float, y: float, heading: float, level: int, actions: np.ndarray, rates: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """States (x, y, heading, level) after each action of ``actions``."""
    steps = actions.size
    xs, ys, hs = np.empty(steps), np.empty(steps), np.empty(steps)
    levels = np.empty(steps, np.int64)
    for t in range(steps):
        x, y, heading, level = fly_one(x, y, heading, level, actions[t], rates)
        xs[t], ys[t], hs[t], levels[t] = x, y, heading, level
    return xs, ys, hs, levels


@inlined
def window_has_open(sums: np.ndarray, step: int, row: int, col: int) -> bool:
    """Whether the visit window around cell (row, col) holds a scorable burning cell."""
    rows, cols = sums.shape[1] - 1, sums.shape[2] - 1
    r0 = min(max(row - WINDOW_HALF, 0), rows)
    r1 = min(max(row + WINDOW_HALF + 1, 0), rows)
    c0 = min(max(col - WINDOW_HALF, 0), cols)
    c1 = min(max(col + WINDOW_HALF + 1, 0), cols)
    if r0 >= r1 or c0 >= c1:
        return False
    total = sums[step, r1, c1] - sums[step, r0, c1] - sums[step, r1, c0] + sums[step, r0, c0]
    return total > 0


@inlined
def claim(
    x: float,
    y: float,
    step: int,
    start: np.ndarray,
    end: np.ndarray,
    first: np.ndarray,
    open_after: int,
    mark: np.ndarray,
    stamp: int,
    write_first: int,
    weight: np.ndarray,
    rows: int,
    cols: int,
) -> float:
    """Visit the cells around (x, y) at fire step ``step`` (``visits.visit_windows``'s test,
    operation for operation): count the burning cells whose ``first`` is at least
    ``open_after`` and whose ``mark`` is not ``stamp``, and mark them (with ``stamp``, and
    ``first = write_first`` when ``write_first`` >= 0) on a map of ``rows`` x ``cols``
    cells; returns their summed ``weight``."""
    row = math.floor(y / CELL_SIZE_M)
    col = math.floor(x / CELL_SIZE_M)
    count = 0.0
    for i in range(-WINDOW_HALF, WINDOW_HALF + 1):
        r = row + i
        if r < 0 or r >= rows:
            continue
        dy = (r + 0.5) * CELL_SIZE_M - y
        dy2 = dy * dy
        for j in range(-WINDOW_HALF, WINDOW_HALF + 1):
            c = col + j
            if c < 0 or c >= cols:
                continue
            dx = (c + 0.5) * CELL_SIZE_M - x
            if dy2 + dx * dx <= _RADIUS2:
                cell = r * cols + c
                if (
                    start[cell] <= step < end[cell]
                    and first[cell] >= open_after
                    and mark[cell] != stamp
                ):
                    mark[cell] = stamp
                    if write_first >= 0:
                        first[cell] = write_first
                    count += weight[cell]
    return count


@kernel
def cover(
    xs: np.ndarray,
    ys: np.ndarray,
    first_decision: int,
    start: np.ndarray,
    end: np.ndarray,
    covered: np.ndarray,
    cols: int,
) -> int:
    """Mark ``covered`` (0/1 per cell of a map ``cols`` cells wide) the cells visited while
    burning by a flight whose point ``u`` is at decision ``first_decision + u``; returns the
    cells newly covered."""
    rows = covered.size // cols
    mark = np.zeros(covered.size, np.int64)
    first = np.zeros(covered.size, np.int64)
    for cell in range(covered.size):
        mark[cell] = 1 if covered[cell] else 0
    ones = np.ones(covered.size)
    count = 0
    for u in range(xs.size):
        step = (first_decision + u) // DECISIONS_PER_FIRE_STEP
        count += int(claim(xs[u], ys[u], step, start, end, first, 0, mark, 1, -1, ones, rows, cols))
    for cell in range(covered.size):
        covered[cell] = mark[cell] == 1
    return count


@kernel
def refresh(
    t0: int,
    xs: np.ndarray,
    ys: np.ndarray,
    decision0: int,
    sample_every: int,
    start: np.ndarray,
    end: np.ndarray,
    sums: np.ndarray,
    first: np.ndarray,
    mark: np.ndarray,
    stamp: int,
    gain: np.ndarray,
    weight: np.ndarray,
) -> None:
    """Credit the plan's points ``t0..`` with the open cells (``first`` = NEVER) they first
    cover, writing ``first`` and ``gain`` (points before ``t0`` keep theirs)."""
    for u in range(t0, xs.size):
        gain[u] = 0
        decision = decision0 + u
        if decision % sample_every != 0:
            continue
        step = decision // DECISIONS_PER_FIRE_STEP
        if not window_has_open(
            sums, step, math.floor(ys[u] / CELL_SIZE_M), math.floor(xs[u] / CELL_SIZE_M)
        ):
            continue
        rows, cols = sums.shape[1] - 1, sums.shape[2] - 1
        gain[u] = claim(
            xs[u], ys[u], step, start, end, first, NEVER, mark, stamp, u, weight, rows, cols
        )


@kernel
def search(
    x0: float,
    y0: float,
    h0: float,
    level0: int,
    decision0: int,
    restarts: np.ndarray,
    base_first: np.ndarray,
    weight: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    sums: np.ndarray,
    rates: np.ndarray,
    sample_every: int,
    max_passes: int,
) -> tuple[np.ndarray, float]:
    """Coordinate descent from each restart (R, T): the best sequence found and its value
    (the summed ``weight`` of the cells newly covered, scored every ``sample_every``-th
    decision). Point ``u`` of a sequence is decision ``decision0 + u``; ``base_first`` is -1
    for cells already covered (by the team or the others' plans) and ``NEVER`` for open ones."""
    count, horizon = restarts.shape
    cells = base_first.size
    rows, cols = sums.shape[1] - 1, sums.shape[2] - 1
    best = restarts[0].copy()
    best_value = -1.0
    mark = np.zeros(cells, np.int64)
    stamp = 0
    gain = np.zeros(horizon)
    prefix = np.zeros(horizon + 1)
    for r in range(count):
        sequence = restarts[r].copy()
        xs, ys, hs, levels = fly_path(x0, y0, h0, level0, sequence, rates)
        first = base_first.copy()
        stamp += 1
        refresh(
            0, xs, ys, decision0, sample_every, start, end, sums, first, mark, stamp, gain, weight
        )
        for u in range(horizon):
            prefix[u + 1] = prefix[u] + gain[u]
        value = prefix[horizon]
        for _ in range(max_passes):
            improved = False
            for t in range(horizon):
                # The flight with action t flipped: as the plan before t, new from t on.
                if t == 0:
                    x, y, heading, level = x0, y0, h0, level0
                else:
                    x, y, heading, level = xs[t - 1], ys[t - 1], hs[t - 1], levels[t - 1]
                stamp += 1
                total = prefix[t]
                for u in range(t, horizon):
                    action = sequence[u] ^ 1 if u == t else sequence[u]
                    x, y, heading, level = fly_one(x, y, heading, level, action, rates)
                    decision = decision0 + u
                    if decision % sample_every != 0:
                        continue
                    step = decision // DECISIONS_PER_FIRE_STEP
                    if not window_has_open(
                        sums, step, math.floor(y / CELL_SIZE_M), math.floor(x / CELL_SIZE_M)
                    ):
                        continue
                    total += claim(
                        x, y, step, start, end, first, t, mark, stamp, -1, weight, rows, cols
                    )
                if total > value + 1e-9:
                    # Take the flip: fly it, forget what the plan covered from t on, re-credit.
                    sequence[t] ^= 1
                    fx, fy, fh, fl = fly_path(
                        xs[t - 1] if t > 0 else x0,
                        ys[t - 1] if t > 0 else y0,
                        hs[t - 1] if t > 0 else h0,
                        levels[t - 1] if t > 0 else level0,
                        sequence[t:],
                        rates,
                    )
                    xs[t:], ys[t:], hs[t:], levels[t:] = fx, fy, fh, fl
                    for cell in range(cells):
                        if t <= first[cell] < NEVER:
                            first[cell] = NEVER
                    stamp += 1
                    refresh(
                        t, xs, ys, decision0, sample_every, start, end, sums, first, mark,
                        stamp, gain, weight,
                    )  # fmt: skip
                    for u in range(t, horizon):
                        prefix[u + 1] = prefix[u] + gain[u]
                    value = prefix[horizon]
                    improved = True
            if not improved:
                break
        if value > best_value:
            best_value = float(value)
            best[:] = sequence
    return best, best_value


__all__ = [
    "NEVER",
    "RATES",
    "claim",
    "cover",
    "fly_one",
    "fly_path",
    "refresh",
    "search",
    "window_has_open",
]
