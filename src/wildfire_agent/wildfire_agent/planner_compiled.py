"""The receding-horizon planner's search as compiled loops (numba): the same plans and the
same score floats as the numpy search of :mod:`wildfire_agent.planner_reference`, ~10x
cheaper (``wildfire bench --only rh`` times both on the same plans).

Each sweep of coordinate descent must find, per row, the first flip of best score and
whether it beats the row's score. Scoring all T flips exactly, as the reference does, costs
a sine, a cosine and, per other aircraft, a ``hypot`` and an ``exp`` for every one of the
T (T + 1) / 2 decisions that the flips change. So a sweep runs in two passes:

1. **Estimate** every flip cheaply (:func:`_estimate_row`): the heading's cosine and sine
   are carried by rotating them with per-level tables, and the proximity term is a
   polynomial of the range, in a loop the compiler turns into vector instructions. An
   estimate lies within ``ESTIMATE_TOLERANCE`` of the exact score (measured errors are
   below 1e-12), unless its flight passes within 1e-6 m of a cell edge, where the fire
   term jumps: the flip is then *unsure*. A flip that changes the sequence only from
   decision j on flies decisions before j as in the last sweep, so each flip's state
   after each decision is kept and the next sweep resumes from it.
2. **Settle** exactly only the flips that can still be the row's answer: the unsure ones
   and those whose estimate is within twice the tolerance of the best estimate. The first
   exact best among them is the reference's ``argmax``: every other flip scores less for
   certain. A row whose every estimate is a tolerance below its score cannot improve, and
   stops, as the reference's does.

The exact flights replay the reference's arithmetic float for float: every sum in the
reference's order (its cumulative sums are sequential), no fast-math (LLVM neither
reassociates nor fuses a multiply and an add), sin, cos and hypot from the C library, which
numpy calls too. Not exp: numpy's float64 exp is its own SIMD routine on AVX-512 machines
and differs from the C library's in the last bit for ~5 % of arguments, so the exact flights
write their ranges out and numpy takes their exp between two compiled calls. Accepting a
row's best flip copies that flip's exact flight into the row's state: float for float what
flying the new sequence from scratch gives (the reference flies it again).

Kernels compile once per machine and are cached beside this file (``cache=True``;
``scripts/setup.sh`` compiles them, so that agent nodes only load them).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from wildfire_agent.dynamics import (
    DECISION_PERIOD_S,
    MAX_BANK_STEPS,
    SPEED_MPS,
    AircraftState,
    turn_rate,
)
from wildfire_agent.planner_reference import (
    AHEAD_M,
    BANK_PENALTY_RAD2,
    LEFT_M,
    NEXT_LEVEL,
    TURN_ANGLE,
    PlanModel,
)
from wildfire_agent.rewards import disc_kernel
from wildfire_sim.grid import CELL_SIZE_M, GRID_SIZE

ESTIMATE_TOLERANCE = 1e-7
"""Bound on |estimated - exact| score of a flip that is not unsure (see the module
docstring); measured errors are below 1e-10 (tests check them)."""
EDGE_GUARD_CELLS = 1e-7
"""A position closer than this (in cells: 1e-6 m) to a cell edge makes its flip unsure."""
_EXP_CUTOFF = -40.0
"""exp below this is taken as 0 in estimates (e^-40 = 4e-18, far inside the tolerance)."""

_kernel = numba.njit(cache=True, nogil=True, error_model="numpy")
# Helpers called per decision are inlined into their callers: a call passing arrays costs
# atomic reference counting, which tripled the estimate pass's time.
_inlined = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

# Columns of the per-bank-level table ``_ARCS``.
_TURN, _AHEAD, _LEFT, _PENALTY, _COS_TURN, _SIN_TURN = range(6)
# Entries of the weight vector (``_weight_vector``).
_W_DISTANCE, _W_CLEAR, _W_BANK, _W_PROXIMITY, _W_SCALE, _W_MAX_DISTANCE, _W_DISC = range(7)
# Columns of the per-point state of a flight: summed turn angle, summed displacements, and
# the reward's fire and bank terms.
_ANGLE, _DX, _DY, _BASE = range(4)
# Rows of the per-row state: the same sums after each decision, and the summed reward.
_REWARD = 3


@_kernel
def _off_map_fire_term(
    distance_m: np.ndarray,
    clear_count: np.ndarray,
    env: int,
    x: float,
    y: float,
    weights: np.ndarray,
) -> float:
    """``rewards.fire_terms`` at one position off the map (where no table entry holds it)."""
    extent = GRID_SIZE * CELL_SIZE_M
    col = math.floor(x / CELL_SIZE_M)
    row = math.floor(y / CELL_SIZE_M)
    outside = math.hypot(max(max(-x, x - extent), 0.0), max(max(-y, y - extent), 0.0))
    last = GRID_SIZE - 1
    nearest = np.float64(distance_m[env, min(max(row, 0), last), min(max(col, 0), last)])
    distance = min(nearest + outside, weights[_W_MAX_DISTANCE])
    pad = (clear_count.shape[-1] - GRID_SIZE) // 2
    if -pad <= row < GRID_SIZE + pad and -pad <= col < GRID_SIZE + pad:
        padded_last = clear_count.shape[-1] - 1
        clear = np.float64(
            clear_count[
                env, min(max(row + pad, 0), padded_last), min(max(col + pad, 0), padded_last)
            ]
        )
    else:
        clear = weights[_W_DISC]
    return -weights[_W_DISTANCE] * distance - weights[_W_CLEAR] * clear


@_inlined
def _on_map(x: float, y: float) -> bool:
    extent = GRID_SIZE * CELL_SIZE_M
    return x >= 0.0 and x <= extent and y >= 0.0 and y <= extent


@_inlined
def _table_cell(position_m: float) -> int:
    """Row or column of ``rewards.fire_term_table`` of an on-map coordinate."""
    return min(max(math.floor(position_m / CELL_SIZE_M), 0), GRID_SIZE)


@_inlined
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


@_kernel
def _fly_exact(
    task_row: np.ndarray,
    task_start: np.ndarray,
    flip: bool,
    sequences: np.ndarray,
    level_at: np.ndarray,
    sums: np.ndarray,
    own: np.ndarray,
    start_level: np.ndarray,
    env: np.ndarray,
    others: np.ndarray,
    table: np.ndarray,
    distance_m: np.ndarray,
    clear_count: np.ndarray,
    weights: np.ndarray,
    arcs: np.ndarray,
    next_level: np.ndarray,
    out_level: np.ndarray,
    out_state: np.ndarray,
    out_range: np.ndarray,
) -> int:
    """Fly each task exactly as the reference does: row ``task_row[i]``'s sequence (its
    action at ``task_start[i]`` flipped if ``flip``) from that decision to the horizon.

    Writes one point per decision, task after task: the bank level, the summed turn angle
    and displacements, the fire and bank terms, the range to each other aircraft. Returns
    the number of points written.
    """
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
            turn = arcs[level, _TURN]
            # The reference's cumulative sums start at their first element (not 0.0 + it).
            angle = turn if t == 0 else angle + turn
            heading = (h0 + angle) - turn
            sin_h, cos_h = math.sin(heading), math.cos(heading)
            ahead, left = arcs[level, _AHEAD], arcs[level, _LEFT]
            dx = ahead * cos_h - left * sin_h
            dy = ahead * sin_h + left * cos_h
            cx = dx if t == 0 else cx + dx
            cy = dy if t == 0 else cy + dy
            x, y = x0 + cx, y0 + cy
            # ``rewards.tabled_fire_terms``: the table on the map, ``fire_terms`` off it.
            if _on_map(x, y):
                fire = table[env[r], _table_cell(y), _table_cell(x)]
            else:
                fire = _off_map_fire_term(distance_m, clear_count, env[r], x, y, weights)
            out_state[point, _BASE] = fire - weights[_W_BANK] * arcs[level, _PENALTY]
            for k in range(others.shape[2]):
                out_range[point, k] = math.hypot(x - others[0, r, k, t], y - others[1, r, k, t])
            out_level[point] = level
            out_state[point, _ANGLE] = angle
            out_state[point, _DX] = cx
            out_state[point, _DY] = cy
            point += 1
    return point


@_kernel
def _score_exact(
    task_row: np.ndarray,
    task_start: np.ndarray,
    horizon: int,
    weights: np.ndarray,
    sums: np.ndarray,
    out_state: np.ndarray,
    closeness: np.ndarray,
    out_reward: np.ndarray,
    totals: np.ndarray,
) -> None:
    """Each point's reward (fire and bank terms less the proximity terms, in the reference's
    order) and each task's total, continuing its row's reward sum before the task."""
    point = 0
    for i in range(task_row.size):
        r, start = task_row[i], task_start[i]
        total = sums[_REWARD, r, start - 1] if start > 0 else 0.0
        for t in range(start, horizon):
            reward = out_state[point, _BASE]
            for k in range(closeness.shape[1]):
                reward -= weights[_W_PROXIMITY] * closeness[point, k]
            out_reward[point] = reward
            total = reward if t == 0 else total + reward
            point += 1
        totals[i] = total


@_kernel
def _accept(
    r: int,
    start: int,
    point: int,
    out_level: np.ndarray,
    out_state: np.ndarray,
    out_reward: np.ndarray,
    level_at: np.ndarray,
    sums: np.ndarray,
) -> None:
    """Copy an exact flight (its points from ``point`` on) into row ``r`` from ``start``."""
    total = sums[_REWARD, r, start - 1] if start > 0 else 0.0
    for t in range(start, level_at.shape[1]):
        level_at[r, t] = out_level[point]
        sums[_ANGLE, r, t] = out_state[point, _ANGLE]
        sums[_DX, r, t] = out_state[point, _DX]
        sums[_DY, r, t] = out_state[point, _DY]
        total = out_reward[point] if t == 0 else total + out_reward[point]
        sums[_REWARD, r, t] = total
        point += 1


@_inlined
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
    scale = -1.0 / (weights[_W_SCALE] * 64.0)
    proximity = weights[_W_PROXIMITY]
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


@_inlined
def _five(near: np.ndarray, quantity: int) -> tuple[float, float, float, float, float]:
    """Row ``quantity`` of ``near`` (the per-level table at 5 levels) as a tuple."""
    return (
        near[quantity, 0], near[quantity, 1], near[quantity, 2], near[quantity, 3],
        near[quantity, 4],
    )  # fmt: skip


@_inlined
def _pick(index: int, five: tuple[float, float, float, float, float]) -> float:
    """``five[index]`` by comparisons, which vectorise (an indexed load would be a gather)."""
    return (
        five[0] if index == 0 else five[1] if index == 1 else five[2] if index == 2
        else five[3] if index == 3 else five[4]
    )  # fmt: skip


@_kernel
def _estimate_row(
    r: int,
    resume_at: int,
    sequences: np.ndarray,
    level_at: np.ndarray,
    sums: np.ndarray,
    own: np.ndarray,
    start_level: np.ndarray,
    env: np.ndarray,
    others: np.ndarray,
    table: np.ndarray,
    distance_m: np.ndarray,
    clear_count: np.ndarray,
    weights: np.ndarray,
    arcs: np.ndarray,
    next_level: np.ndarray,
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
    horizon = sequences.shape[1]
    e = env[r]
    x0, y0, h0 = own[r, 0], own[r, 1], own[r, 2]
    to_cells = 1.0 / CELL_SIZE_M
    edge_limit = 0.5 - EDGE_GUARD_CELLS
    half_extent = GRID_SIZE * CELL_SIZE_M / 2.0
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
        ahead5, left5, penalty5 = _five(near, _AHEAD), _five(near, _LEFT), _five(near, _PENALTY)
        cos5, sin5 = _five(near, _COS_TURN), _five(near, _SIN_TURN)
        bank_weight = weights[_W_BANK]
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
            if max(abs(x - half_extent), abs(y - half_extent)) <= half_extent:
                # On the map (its far edge included): cell indices 0..GRID_SIZE.
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


@_kernel
def _estimate_flips(
    active: int,
    rows: np.ndarray,
    scores: np.ndarray,
    sequences: np.ndarray,
    level_at: np.ndarray,
    sums: np.ndarray,
    own: np.ndarray,
    start_level: np.ndarray,
    env: np.ndarray,
    others: np.ndarray,
    table: np.ndarray,
    distance_m: np.ndarray,
    clear_count: np.ndarray,
    weights: np.ndarray,
    arcs: np.ndarray,
    next_level: np.ndarray,
    last_flip: np.ndarray,
    flights: np.ndarray,
    flight_levels: np.ndarray,
    estimate: np.ndarray,
    unsure: np.ndarray,
    task_row: np.ndarray,
    task_start: np.ndarray,
    row_tasks: np.ndarray,
    out_level: np.ndarray,
    out_state: np.ndarray,
    out_range: np.ndarray,
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
            own,
            start_level,
            env,
            others,
            table,
            distance_m,
            clear_count,
            weights,
            arcs,
            next_level,
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
    points = _fly_exact(
        task_row[:tasks], task_start[:tasks], True, sequences, level_at, sums, own,
        start_level, env, others, table, distance_m, clear_count, weights, arcs, next_level,
        out_level, out_state, out_range,
    )  # fmt: skip
    return tasks, points


@_kernel
def _take_best_flips(
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
    out_level: np.ndarray,
    out_state: np.ndarray,
    out_reward: np.ndarray,
    level_at: np.ndarray,
    sums: np.ndarray,
    last_flip: np.ndarray,
) -> int:
    """Score the exact flights (:func:`_score_exact`, their proximity terms' exp given in
    ``closeness``) and flip each active row's first exact best where it beats the row's
    score; the rows that improved are moved to the front of ``rows``, and their count
    returned."""
    horizon = sequences.shape[1]
    _score_exact(
        task_row, task_start, horizon, weights, sums, out_state, closeness, out_reward, totals
    )
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
            _accept(
                r, task_start[best], best_point, out_level, out_state, out_reward, level_at, sums
            )
            rows[kept] = r
            kept += 1
    return kept


@_kernel
def _constant_bank_track(
    x_m: np.ndarray, y_m: np.ndarray, heading_rad: np.ndarray, rate: np.ndarray, steps: int
) -> tuple[np.ndarray, np.ndarray]:
    """``dynamics.constant_bank_track`` of flat arrays (M,), float for float: the same arcs
    from the C library's sin and cos, the heading wrapped after each step as ``wrap_angle``
    wraps it."""
    out_x = np.empty((x_m.size, steps))
    out_y = np.empty((x_m.size, steps))
    two_pi = 2.0 * np.pi
    for m in range(x_m.size):
        x, y, heading, turn = x_m[m], y_m[m], heading_rad[m], rate[m]
        for t in range(steps):
            new_heading = heading + turn * DECISION_PERIOD_S
            if turn != 0.0:
                x += SPEED_MPS / turn * (math.sin(new_heading) - math.sin(heading))
                y += SPEED_MPS / turn * (math.cos(heading) - math.cos(new_heading))
            else:
                x += SPEED_MPS * DECISION_PERIOD_S * math.cos(heading)
                y += SPEED_MPS * DECISION_PERIOD_S * math.sin(heading)
            out_x[m, t], out_y[m, t] = x, y
            # Python's float modulo, as numpy's: the remainder takes the divisor's sign.
            heading = np.pi - (np.pi - new_heading) % two_pi
    return out_x, out_y


def constant_bank_track(state: AircraftState, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """``dynamics.constant_bank_track`` compiled: positions (x, y), each (..., steps), of
    aircraft holding their bank, the same floats (tested)."""
    shape = np.shape(state.x_m)
    x, y, heading, rate = (
        np.ascontiguousarray(np.reshape(field, -1), np.float64)
        # The turn rate from numpy's tan, as dynamics computes it.
        for field in (state.x_m, state.y_m, state.heading_rad, turn_rate(state.bank_rad))
    )
    x, y = _constant_bank_track(x, y, heading, rate, steps)
    return x.reshape(*shape, steps), y.reshape(*shape, steps)


_ARCS = np.ascontiguousarray(
    np.stack(
        [TURN_ANGLE, AHEAD_M, LEFT_M, BANK_PENALTY_RAD2, np.cos(TURN_ANGLE), np.sin(TURN_ANGLE)],
        axis=-1,
    )
)
"""Per bank level (row ``bank_steps + 10``): turn angle, metres ahead, metres left, phi^2,
cos and sin of the turn, side by side in memory. The kernels take tables as arguments
rather than compiling them in as constants, which their disk cache would keep after the
tables changed."""
_NEXT = np.ascontiguousarray(NEXT_LEVEL, dtype=np.int64)


def _weight_vector(model: PlanModel) -> np.ndarray:
    """The reward weights the kernels read, in the order of the ``_W_*`` indices."""
    weights = model.weights
    return np.array(
        [
            weights.distance,
            weights.clear_cells,
            weights.bank,
            weights.proximity,
            weights.proximity_scale_m,
            weights.max_distance_m,
            float(disc_kernel(weights.clear_radius_m).sum()),
        ]
    )


class _Search:
    """The buffers and state of one search: one row per sequence being improved."""

    def __init__(self, model: PlanModel, sequences: np.ndarray) -> None:
        self.sequences = np.array(sequences, dtype=np.int64)
        count, horizon = self.sequences.shape
        own = model.own
        self.weights = _weight_vector(model)
        self.scene = (
            np.stack([own.x_m[:, 0], own.y_m[:, 0], own.heading_rad[:, 0]], -1).astype(np.float64),
            np.ascontiguousarray(own.bank_steps[:, 0] + MAX_BANK_STEPS, dtype=np.int64),
            np.ascontiguousarray(model.env, dtype=np.int64),
            np.ascontiguousarray(np.stack([model.others_x, model.others_y]), dtype=np.float64),
            np.ascontiguousarray(model.table, dtype=np.float64),
            np.ascontiguousarray(model.maps.distance_m),
            np.ascontiguousarray(model.maps.clear_count),
            self.weights,
            _ARCS,
            _NEXT,
        )
        # Each row's state after each decision of its current sequence: the per-point sums
        # (``_ANGLE``, ``_DX``, ``_DY``) and the summed reward (``_REWARD``); its bank levels.
        self.sums = np.empty((4, count, horizon))
        self.level_at = np.empty((count, horizon), np.int64)
        # Exact flights: at most one per (row, flip), T - flip points each.
        points = count * horizon * (horizon + 1) // 2
        self.out_level = np.empty(points, np.int64)
        self.out_state, self.out_reward = np.empty((points, 4)), np.empty(points)
        self.out_range = np.empty((points, model.others_x.shape[1]))
        self.task_row = np.empty(count * horizon, np.int64)
        self.task_start = np.empty(count * horizon, np.int64)
        self.totals = np.empty(count * horizon)
        self.estimate = np.empty((count, horizon))
        self.unsure = np.empty((count, horizon), np.bool_)
        self.row_tasks = np.ones(count, np.int64)
        # Each row's flips as last estimated (see ``_estimate_row``), and its last flip.
        self.flights = np.empty((count, horizon, 6, horizon))
        self.flight_levels = np.empty((count, horizon, horizon), np.int64)
        self.last_flip = np.full(count, -1, np.int64)
        # Rows still being improved: the first ``active`` of ``rows``.
        self.rows = np.arange(count, dtype=np.int64)
        self.active = count
        # Fly every row's sequence exactly and take it as the row's state (an unflipped
        # flight from decision 0 "beats" a score of -inf).
        self.scores = np.full(count, -np.inf)
        self.task_row[:count], self.task_start[:count] = self.rows, 0
        points = _fly_exact(
            self.rows, self.task_start[:count], False, self.sequences, self.level_at,
            self.sums, *self.scene, self.out_level, self.out_state, self.out_range,
        )  # fmt: skip
        # The take flips what it accepts: flip the sequences first, so that it flips them back.
        self.sequences[:, 0] ^= 1
        self._take(count, points)
        self.active = count
        self.last_flip[:] = -1

    def _take(self, tasks: int, points: int) -> int:
        """Score the ``tasks`` exact flights (``points`` points) and take each active row's
        best; returns the number of rows that improved."""
        # numpy's exp, as the reference's (see the module docstring).
        closeness = np.exp(-self.out_range[:points] / self.weights[_W_SCALE])
        return _take_best_flips(
            self.active, self.rows, self.row_tasks, self.task_row[:tasks],
            self.task_start[:tasks], self.weights, closeness, self.totals, self.scores,
            self.sequences, self.out_level, self.out_state, self.out_reward, self.level_at,
            self.sums, self.last_flip,
        )  # fmt: skip

    def estimate_flips(self) -> tuple[int, int]:
        """Estimate every flip of the active rows and fly exactly those that can still win:
        how many, and their points."""
        return _estimate_flips(
            self.active, self.rows, self.scores, self.sequences, self.level_at, self.sums,
            *self.scene, self.last_flip, self.flights, self.flight_levels, self.estimate,
            self.unsure, self.task_row, self.task_start, self.row_tasks, self.out_level,
            self.out_state, self.out_range,
        )  # fmt: skip

    def sweep(self) -> bool:
        """One sweep of coordinate descent; False once no row improved."""
        self.active = self._take(*self.estimate_flips())
        return self.active > 0


def search(
    model: PlanModel, sequences: np.ndarray, max_sweeps: int
) -> tuple[np.ndarray, np.ndarray]:
    """Coordinate descent from ``sequences`` (N, T), one per row of ``model``: the same local
    optima (N, T) and scores (N,) as ``planner_reference.search``."""
    state = _Search(model, sequences)
    for _ in range(max_sweeps):
        if not state.sweep():
            break
    return state.sequences, state.scores


def flip_estimates(model: PlanModel, sequences: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Estimated score (N, T) of each single-action flip of ``sequences`` (N, T), and which
    estimates are unsure (their flight passes a cell edge): what a sweep settles from."""
    state = _Search(model, sequences)
    state.estimate_flips()
    return state.estimate.copy(), state.unsure.copy()


def compile_kernels() -> None:
    """Compile (or load from the disk cache) every kernel: one small search."""
    from wildfire_agent.planner_reference import plan_model
    from wildfire_agent.rewards import ObservationRewardWeights, fire_field_maps

    burning = np.zeros((1, GRID_SIZE, GRID_SIZE), dtype=bool)
    burning[0, 45:55, 45:55] = True
    weights = ObservationRewardWeights()
    one = np.ones(1)
    state = AircraftState(500.0 * one, 300.0 * one, one, np.zeros(1, np.int64))
    others = AircraftState(*(field[:, None] for field in state))
    model = plan_model(
        state,
        np.zeros(1),
        fire_field_maps(burning, weights),
        constant_bank_track(others, 8),
        weights,
    )
    search(model, np.zeros((1, 8), np.int64), max_sweeps=2)


__all__ = [
    "ESTIMATE_TOLERANCE",
    "compile_kernels",
    "constant_bank_track",
    "flip_estimates",
    "search",
]
