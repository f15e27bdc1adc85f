"""The compiled kernels of the receding-horizon planner's search (numba).

:mod:`wildfire_agent.planner_compiled` explains the two passes of a sweep and drives them;
this module holds the loops: :func:`fly_exact` and :func:`take_best_flips` (exact flights
and their scores, float for float the reference's), :func:`estimate_flips` (the cheap
estimate of every flip, and which flips must be settled exactly).

Every kernel that calls another lives in this one file: numba's disk cache (``cache=True``)
checks only the source file of the function it compiled, so a callee edited in another file
would leave its callers' cached machine code stale.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from wildfire_agent.dynamics import MAX_BANK_STEPS
from wildfire_sim.grid import CELL_SIZE_M

ESTIMATE_TOLERANCE = 1e-7
"""Bound on |estimated - exact| score of a flip that is not unsure (see the module
docstring); measured errors are below 1e-10 (tests check them)."""
EDGE_GUARD_CELLS = 1e-7
"""A position closer than this (in cells: 1e-6 m) to a cell edge makes its flip unsure."""
_EXP_CUTOFF = -40.0
"""exp below this is taken as 0 in estimates (e^-40 = 4e-18, far inside the tolerance)."""

kernel = numba.njit(cache=True, nogil=True, error_model="numpy")
# Helpers called per decision are inlined into their callers: a call passing arrays costs
# atomic reference counting, which tripled the estimate pass's time.
inlined = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

Scene = tuple[
    np.ndarray,
    np.ndarray,
    np.ndarray,
    np.ndarray,
    np.ndarray,
    np.ndarray,
    np.ndarray,
    np.ndarray,
    np.ndarray,
    np.ndarray,
]
"""What every row's flights fly over, passed to the kernels as one tuple: ``own`` (N, 3:
x, y, heading), ``start_level`` (N,), ``env`` (N,), ``others`` (2, N, K, T: x and y of the
other aircraft), the fire-term ``table``, ``distance_m`` and ``clear_count`` (off the map),
the ``weights``, the per-bank-level ``arcs`` and ``next_level`` (as
``planner_compiled._Search`` builds it)."""

Flown = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""The points of exact flights, one per decision flown, flight after flight: bank level,
state (columns ``_ANGLE``, ``_DX``, ``_DY``, ``_BASE``), range to each other aircraft,
reward."""

# Columns of the per-bank-level table (``planner_compiled.ARCS``).
TURN, AHEAD, LEFT, PENALTY, COS_TURN, SIN_TURN = range(6)
# Entries of the weight vector (``planner_compiled.weight_vector``).
W_DISTANCE, W_CLEAR, W_BANK, W_PROXIMITY, W_SCALE, W_MAX_DISTANCE, W_DISC = range(7)
# Columns of the per-point state of a flight: summed turn angle, summed displacements, and
# the reward's fire and bank terms.
_ANGLE, _DX, _DY, _BASE = range(4)
# Rows of the per-row state: the same sums after each decision, and the summed reward.
_REWARD = 3


@kernel
def _off_map_fire_term(
    distance_m: np.ndarray,
    clear_count: np.ndarray,
    env: int,
    x: float,
    y: float,
    weights: np.ndarray,
) -> float:
    """``rewards.fire_terms`` at one position off the map (where no table entry holds it)."""
    height, width = distance_m.shape[1], distance_m.shape[2]
    col = math.floor(x / CELL_SIZE_M)
    row = math.floor(y / CELL_SIZE_M)
    outside = math.hypot(
        max(max(-x, x - width * CELL_SIZE_M), 0.0), max(max(-y, y - height * CELL_SIZE_M), 0.0)
    )
    nearest = np.float64(distance_m[env, min(max(row, 0), height - 1), min(max(col, 0), width - 1)])
    distance = min(nearest + outside, weights[W_MAX_DISTANCE])
    pad = (clear_count.shape[-1] - width) // 2
    if -pad <= row < height + pad and -pad <= col < width + pad:
        clear = np.float64(
            clear_count[
                env,
                min(max(row + pad, 0), height + 2 * pad - 1),
                min(max(col + pad, 0), width + 2 * pad - 1),
            ]
        )
    else:
        clear = weights[W_DISC]
    return -weights[W_DISTANCE] * distance - weights[W_CLEAR] * clear


@inlined
def _on_map(x: float, y: float, height: int, width: int) -> bool:
    """On a map of ``height`` x ``width`` cells, its far edges included."""
    return x >= 0.0 and x <= width * CELL_SIZE_M and y >= 0.0 and y <= height * CELL_SIZE_M


@inlined
def _table_cell(position_m: float, cells: int) -> int:
    """Row or column of ``rewards.fire_term_table`` of an on-map coordinate (``cells`` the
    map's cells along that axis)."""
    return min(max(math.floor(position_m / CELL_SIZE_M), 0), cells)


@inlined
def _flight_start(
    r: int, start: int, level_at: np.ndarray, sums: np.ndarray, start_level: np.ndarray
) -> tuple[int, float, float, float, float]:
    """Row ``r``'s bank level, angle sum, displacement sums and reward sum before ``start``."""
    if start == 0:
        return start_level[r], 0.0, 0.0, 0.0, 0.0
    before = start - 1
    return (
        level_at[r, before],
        sums[_ANGLE, r, before],
        sums[_DX, r, before],
        sums[_DY, r, before],
        sums[_REWARD, r, before],
    )


@kernel
def fly_exact(
    task_row: np.ndarray,
    task_start: np.ndarray,
    flip: bool,
    sequences: np.ndarray,
    level_at: np.ndarray,
    sums: np.ndarray,
    scene: Scene,
    flown: Flown,
) -> int:
    """Fly each task exactly as the reference does: row ``task_row[i]``'s sequence (its
    action at ``task_start[i]`` flipped if ``flip``) from that decision to the horizon.

    Writes one point per decision, task after task: the bank level, the summed turn angle
    and displacements, the fire and bank terms, the range to each other aircraft. Returns
    the number of points written.
    """
    own, start_level, env, others, table, distance_m, clear_count, weights, arcs, next_level = scene
    height, width = distance_m.shape[1], distance_m.shape[2]
    out_level, out_state, out_range, _ = flown
    horizon = sequences.shape[1]
    point = 0
    for i in range(task_row.size):
        r, start = task_row[i], task_start[i]
        level, angle, cx, cy, _ = _flight_start(r, start, level_at, sums, start_level)
        x0, y0, h0 = own[r, 0], own[r, 1], own[r, 2]
        for t in range(start, horizon):
            action = sequences[r, t]
            if flip and t == start:
                action ^= 1
            level = next_level[level, action]
            turn = arcs[level, TURN]
            # The reference's cumulative sums start at their first element (not 0.0 + it).
            angle = turn if t == 0 else angle + turn
            heading = (h0 + angle) - turn
            sin_h, cos_h = math.sin(heading), math.cos(heading)
            ahead, left = arcs[level, AHEAD], arcs[level, LEFT]
            dx = ahead * cos_h - left * sin_h
            dy = ahead * sin_h + left * cos_h
            cx = dx if t == 0 else cx + dx
            cy = dy if t == 0 else cy + dy
            x, y = x0 + cx, y0 + cy
            # ``rewards.tabled_fire_terms``: the table on the map, ``fire_terms`` off it.
            if _on_map(x, y, height, width):
                fire = table[env[r], _table_cell(y, height), _table_cell(x, width)]
            else:
                fire = _off_map_fire_term(distance_m, clear_count, env[r], x, y, weights)
            out_state[point, _BASE] = fire - weights[W_BANK] * arcs[level, PENALTY]
            for k in range(others.shape[2]):
                out_range[point, k] = math.hypot(x - others[0, r, k, t], y - others[1, r, k, t])
            out_level[point] = level
            out_state[point, _ANGLE] = angle
            out_state[point, _DX] = cx
            out_state[point, _DY] = cy
            point += 1
    return point


@kernel
def _score_exact(
    task_row: np.ndarray,
    task_start: np.ndarray,
    horizon: int,
    weights: np.ndarray,
    sums: np.ndarray,
    flown: Flown,
    closeness: np.ndarray,
    totals: np.ndarray,
) -> None:
    """Each point's reward (fire and bank terms less the proximity terms, in the reference's
    order) and each task's total, continuing its row's reward sum before the task."""
    _, out_state, _, out_reward = flown
    point = 0
    for i in range(task_row.size):
        r, start = task_row[i], task_start[i]
        total = sums[_REWARD, r, start - 1] if start > 0 else 0.0
        for t in range(start, horizon):
            reward = out_state[point, _BASE]
            for k in range(closeness.shape[1]):
                reward -= weights[W_PROXIMITY] * closeness[point, k]
            out_reward[point] = reward
            total = reward if t == 0 else total + reward
            point += 1
        totals[i] = total


@kernel
def _accept(
    r: int,
    start: int,
    point: int,
    flown: Flown,
    level_at: np.ndarray,
    sums: np.ndarray,
) -> None:
    """Copy an exact flight (its points from ``point`` on) into row ``r`` from ``start``."""
    out_level, out_state, _, out_reward = flown
    total = sums[_REWARD, r, start - 1] if start > 0 else 0.0
    for t in range(start, level_at.shape[1]):
        level_at[r, t] = out_level[point]
        sums[_ANGLE, r, t] = out_state[point, _ANGLE]
        sums[_DX, r, t] = out_state[point, _DX]
        sums[_DY, r, t] = out_state[point, _DY]
        total = out_reward[point] if t == 0 else total + out_reward[point]
        sums[_REWARD, r, t] = total
        point += 1


@inlined
def _subtract_closeness(
    flights: np.ndarray, count: int, offset_x: float, offset_y: float, weights: np.ndarray
) -> None:
    """Subtract the proximity term to one other aircraft from the summed reward of the
    ``count`` flights of ``flights`` (6, T) (positions: the summed displacements plus the
    ownship's start less the other's position, ``offset``).

    exp(-range / c) is (e^z)^64 for z = -range / (64 c), clamped at -40 / 64 (e^-40 is
    4e-18: nothing left to add); e^z by its Taylor series to z^11: absolute error < 1e-14.
    No table and no branch, so the loop runs on vector instructions.
    """
    scale = -1.0 / (weights[W_SCALE] * 64.0)
    proximity = weights[W_PROXIMITY]
    for j in range(count):
        dx = flights[2, j] + offset_x
        dy = flights[3, j] + offset_y
        z = max(math.sqrt(dx * dx + dy * dy) * scale, _EXP_CUTOFF / 64.0)
        power = 1.0 + z * (
            1.0 + z * (1.0 / 2.0 + z * (1.0 / 6.0 + z * (1.0 / 24.0 + z * (1.0 / 120.0 + z * (
                1.0 / 720.0 + z * (1.0 / 5040.0 + z * (1.0 / 40320.0 + z * (
                    1.0 / 362880.0 + z * (1.0 / 3628800.0 + z / 39916800.0)
                )))
            )))))
        )  # fmt: skip
        for _ in range(6):
            power *= power
        flights[4, j] -= proximity * power


@inlined
def _five(near: np.ndarray, quantity: int) -> tuple[float, float, float, float, float]:
    """Row ``quantity`` of ``near`` (the per-level table at 5 levels) as a tuple."""
    return (
        near[quantity, 0], near[quantity, 1], near[quantity, 2], near[quantity, 3],
        near[quantity, 4],
    )  # fmt: skip


@inlined
def _pick(index: int, five: tuple[float, float, float, float, float]) -> float:
    """``five[index]`` by comparisons, which vectorise (an indexed load would be a gather)."""
    return (
        five[0] if index == 0 else five[1] if index == 1 else five[2] if index == 2
        else five[3] if index == 3 else five[4]
    )  # fmt: skip


@kernel
def _estimate_row(
    r: int,
    resume_at: int,
    sequences: np.ndarray,
    level_at: np.ndarray,
    sums: np.ndarray,
    scene: Scene,
    flights: np.ndarray,
    flight_levels: np.ndarray,
    estimate: np.ndarray,
    unsure: np.ndarray,
) -> None:
    """Estimate every flip of row ``r`` into ``estimate`` (T,), ``unsure`` (T,).

    The flips fly in lockstep: at decision t, every flip j <= t takes its step t. Each
    flip's state after each decision is kept in ``flights`` (T decisions, 6, T flips: the
    heading's cosine and sine, the summed displacements, the summed reward, unsure as 0/1)
    and ``flight_levels`` (T, T), so that the next sweep resumes from it: when the row's
    sequence changed only from decision ``resume_at`` on (its last flip), the flips before
    it flew the same decisions up to there, and pick up from their state before it.
    """
    own, start_level, env, others, table, distance_m, clear_count, weights, arcs, _ = scene
    horizon = sequences.shape[1]
    e = env[r]
    x0, y0, h0 = own[r, 0], own[r, 1], own[r, 2]
    to_cells = 1.0 / CELL_SIZE_M
    edge_limit = 0.5 - EDGE_GUARD_CELLS
    # Half the map's extent along each axis: the on-map test below.
    half_height = distance_m.shape[1] * CELL_SIZE_M / 2.0
    half_width = distance_m.shape[2] * CELL_SIZE_M / 2.0
    near = np.empty((6, 5))
    # State of every flip before the next decision: after the decision before it.
    before = flights[max(resume_at - 1, 0)]
    levels_before = flight_levels[max(resume_at - 1, 0)]
    for t in range(resume_at, horizon):
        after, levels_after = flights[t], flight_levels[t]
        # Flip t joins (in the column it has no state in yet) from the state the row's
        # sequence reached before decision t.
        level, angle, cx, cy, total = _flight_start(r, t, level_at, sums, start_level)
        levels_before[t] = level
        before[0, t], before[1, t] = math.cos(h0 + angle), math.sin(h0 + angle)
        before[2, t], before[3, t], before[4, t], before[5, t] = cx, cy, total, 0.0
        action = sequences[r, t]
        # Every flip's bank level lies within 2 of the row's own level after decision t (a
        # flip moves one action's level by 2, and the bank limit can only bring it closer),
        # so the per-level tables narrow to 5 entries, picked without a look-up: the loop
        # over the flips then runs on vector instructions.
        centre = level_at[r, t]
        for d in range(5):
            near_level = min(max(centre + d - 2, 0), 2 * MAX_BANK_STEPS)
            for q in range(6):
                near[q, d] = arcs[near_level, q]
        ahead5, left5, penalty5 = _five(near, AHEAD), _five(near, LEFT), _five(near, PENALTY)
        cos5, sin5 = _five(near, COS_TURN), _five(near, SIN_TURN)
        bank_weight = weights[W_BANK]
        step = 2 * action - 1
        top = 2 * MAX_BANK_STEPS
        for j in range(t + 1):
            level_before = levels_before[j]
            proposed = level_before + (-step if j == t else step)
            level = proposed if 0 <= proposed <= top else level_before
            d = level - centre + 2
            ahead, left, penalty = _pick(d, ahead5), _pick(d, left5), _pick(d, penalty5)
            cos_turn, sin_turn = _pick(d, cos5), _pick(d, sin5)
            cos_h, sin_h = before[0, j], before[1, j]
            cx = before[2, j] + (ahead * cos_h - left * sin_h)
            cy = before[3, j] + (ahead * sin_h + left * cos_h)
            col_f, row_f = (x0 + cx) * to_cells, (y0 + cy) * to_cells
            # A position this close to a cell edge may sit in the other cell exactly.
            near_edge = (
                max(abs(col_f - math.floor(col_f) - 0.5), abs(row_f - math.floor(row_f) - 0.5))
                > edge_limit
            )
            levels_after[j] = level
            after[0, j] = cos_h * cos_turn - sin_h * sin_turn
            after[1, j] = sin_h * cos_turn + cos_h * sin_turn
            after[2, j], after[3, j] = cx, cy
            after[4, j] = before[4, j] - bank_weight * penalty
            after[5, j] = 1.0 if near_edge else before[5, j]
        for j in range(t + 1):
            x, y = x0 + after[2, j], y0 + after[3, j]
            if abs(x - half_width) <= half_width and abs(y - half_height) <= half_height:
                # On the map (its far edge included): cell indices 0..rows (cols).
                after[4, j] += table[e, math.floor(y * to_cells), math.floor(x * to_cells)]
            else:
                after[4, j] += _off_map_fire_term(distance_m, clear_count, e, x, y, weights)
        for k in range(others.shape[2]):
            _subtract_closeness(
                after, t + 1, x0 - others[0, r, k, t], y0 - others[1, r, k, t], weights
            )
        before, levels_before = after, levels_after
    for j in range(horizon):
        estimate[j] = before[4, j]
        unsure[j] = before[5, j] != 0.0


@kernel
def estimate_flips(
    active: int,
    rows: np.ndarray,
    scores: np.ndarray,
    sequences: np.ndarray,
    level_at: np.ndarray,
    sums: np.ndarray,
    scene: Scene,
    last_flip: np.ndarray,
    flights: np.ndarray,
    flight_levels: np.ndarray,
    estimate: np.ndarray,
    unsure: np.ndarray,
    task_row: np.ndarray,
    task_start: np.ndarray,
    row_tasks: np.ndarray,
    flown: Flown,
) -> tuple[int, int]:
    """Estimate every flip of the ``active`` first rows of ``rows`` (into ``estimate[i]``,
    ``unsure[i]``), list the flips to settle exactly: ``row_tasks[i]`` of them for row i
    (0: the row cannot improve), in flip order, in ``task_row`` / ``task_start``, and fly
    them exactly (:func:`_fly_exact`). Returns the number of flips listed and of points."""
    horizon = sequences.shape[1]
    tasks = 0
    for i in range(active):
        r = rows[i]
        _estimate_row(
            r,
            max(last_flip[r], 0),
            sequences,
            level_at,
            sums,
            scene,
            flights[r],
            flight_levels[r],
            estimate[i],
            unsure[i],
        )
        best = -np.inf
        any_unsure = False
        for j in range(horizon):
            if unsure[i, j]:
                any_unsure = True
            else:
                best = max(best, estimate[i, j])
        first = tasks
        if any_unsure or best + ESTIMATE_TOLERANCE > scores[r]:
            for j in range(horizon):
                if unsure[i, j] or estimate[i, j] >= best - 2.0 * ESTIMATE_TOLERANCE:
                    task_row[tasks] = r
                    task_start[tasks] = j
                    tasks += 1
        row_tasks[i] = tasks - first
    points = fly_exact(
        task_row[:tasks], task_start[:tasks], True, sequences, level_at, sums, scene, flown
    )  # fmt: skip
    return tasks, points


@kernel
def take_best_flips(
    active: int,
    rows: np.ndarray,
    row_tasks: np.ndarray,
    task_row: np.ndarray,
    task_start: np.ndarray,
    weights: np.ndarray,
    closeness: np.ndarray,
    totals: np.ndarray,
    scores: np.ndarray,
    sequences: np.ndarray,
    flown: Flown,
    level_at: np.ndarray,
    sums: np.ndarray,
    last_flip: np.ndarray,
) -> int:
    """Score the exact flights (:func:`_score_exact`, their proximity terms' exp given in
    ``closeness``) and flip each active row's first exact best where it beats the row's
    score; the rows that improved are moved to the front of ``rows``, and their count
    returned."""
    horizon = sequences.shape[1]
    _score_exact(task_row, task_start, horizon, weights, sums, flown, closeness, totals)
    kept = 0
    task = 0
    point = 0
    for i in range(active):
        r = rows[i]
        best = -1
        best_point = 0
        for _ in range(row_tasks[i]):
            if best < 0 or totals[task] > totals[best]:
                best, best_point = task, point
            point += horizon - task_start[task]
            task += 1
        if best >= 0 and totals[best] > scores[r]:
            scores[r] = totals[best]
            sequences[r, task_start[best]] ^= 1
            last_flip[r] = task_start[best]
            _accept(r, task_start[best], best_point, flown, level_at, sums)
            rows[kept] = r
            kept += 1
    return kept


__all__ = [
    "ESTIMATE_TOLERANCE",
    "Flown",
    "Scene",
    "estimate_flips",
    "fly_exact",
    "kernel",
    "take_best_flips",
]
