"""The receding-horizon planner's search as compiled loops (numba): the same plans and the
same score floats as the numpy search of :mod:`wildfire_agent.planner_reference`, ~10x
cheaper (``wildfire bench --only rh`` times both on the same plans).

Each sweep of coordinate descent must find, per row, the first flip of best score and
whether it beats the row's score. Scoring all T flips exactly, as the reference does, costs
a sine, a cosine and, per other aircraft, a ``hypot`` and an ``exp`` for every one of the
T (T + 1) / 2 decisions that the flips change. So a sweep runs in two passes:

1. **Estimate** every flip cheaply (``planner_kernels._estimate_row``): the heading's cosine
   and sine are carried by rotating them with per-level tables, and the proximity term is a
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

The loops are :mod:`wildfire_agent.planner_kernels`; this module prepares their tables and
buffers and runs the sweeps. Kernels compile once per machine and are cached beside their
file (``cache=True``; ``scripts/setup.sh`` compiles them, so that agent nodes only load
them).
"""

from __future__ import annotations

import math

import numpy as np

from wildfire_agent import planner_kernels as kernels
from wildfire_agent.dynamics import (
    DECISION_PERIOD_S,
    MAX_BANK_STEPS,
    SPEED_MPS,
    AircraftState,
    turn_rate,
)
from wildfire_agent.planner_kernels import ESTIMATE_TOLERANCE, kernel
from wildfire_agent.planner_reference import (
    AHEAD_M,
    BANK_PENALTY_RAD2,
    LEFT_M,
    NEXT_LEVEL,
    TURN_ANGLE,
    PlanModel,
)
from wildfire_agent.rewards import disc_kernel
from wildfire_sim.grid import PAPER_MAP


@kernel
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


def _arcs_table() -> np.ndarray:
    """Per bank level (row ``bank_steps + 10``): turn angle, metres ahead, metres left, phi^2,
    cos and sin of the turn, side by side in memory (columns as the kernels name them)."""
    arcs = np.empty((TURN_ANGLE.size, 6))
    arcs[:, kernels.TURN], arcs[:, kernels.AHEAD], arcs[:, kernels.LEFT] = (
        TURN_ANGLE,
        AHEAD_M,
        LEFT_M,
    )
    arcs[:, kernels.PENALTY] = BANK_PENALTY_RAD2
    arcs[:, kernels.COS_TURN], arcs[:, kernels.SIN_TURN] = np.cos(TURN_ANGLE), np.sin(TURN_ANGLE)
    return arcs


# The kernels take tables as arguments rather than compiling them in as constants, which
# their disk cache would keep after the tables changed.
_ARCS = _arcs_table()
_NEXT = np.ascontiguousarray(NEXT_LEVEL, dtype=np.int64)


def _weight_vector(model: PlanModel) -> np.ndarray:
    """The reward weights the kernels read, at their ``W_*`` indices."""
    weights = model.weights
    vector = np.empty(7)
    vector[kernels.W_DISTANCE], vector[kernels.W_CLEAR] = weights.distance, weights.clear_cells
    vector[kernels.W_BANK], vector[kernels.W_PROXIMITY] = weights.bank, weights.proximity
    vector[kernels.W_SCALE], vector[kernels.W_MAX_DISTANCE] = (
        weights.proximity_scale_m,
        weights.max_distance_m,
    )
    vector[kernels.W_DISC] = float(disc_kernel(weights.clear_radius_m).sum())
    return vector


class _Search:
    """The buffers and state of one search: one row per sequence being improved."""

    def __init__(self, model: PlanModel, sequences: np.ndarray) -> None:
        self.sequences = np.array(sequences, dtype=np.int64)
        count, horizon = self.sequences.shape
        own = model.own
        self.weights = _weight_vector(model)
        self.scene: kernels.Scene = (
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
        self.flown: kernels.Flown = (
            np.empty(points, np.int64),
            np.empty((points, 4)),
            np.empty((points, model.others_x.shape[1])),
            np.empty(points),
        )
        self.task_row = np.empty(count * horizon, np.int64)
        self.task_start = np.empty(count * horizon, np.int64)
        self.totals = np.empty(count * horizon)
        self.estimate = np.empty((count, horizon))
        self.unsure = np.empty((count, horizon), np.bool_)
        self.row_tasks = np.ones(count, np.int64)
        # Each row's flips as last estimated (``planner_kernels._estimate_row``), its last flip.
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
        points = kernels.fly_exact(
            self.rows, self.task_start[:count], False, self.sequences, self.level_at, self.sums,
            self.scene, self.flown,
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
        ranges = self.flown[2][:points]
        closeness = np.exp(-ranges / self.weights[kernels.W_SCALE])
        return kernels.take_best_flips(
            self.active, self.rows, self.row_tasks, self.task_row[:tasks],
            self.task_start[:tasks], self.weights, closeness, self.totals, self.scores,
            self.sequences, self.flown, self.level_at, self.sums, self.last_flip,
        )  # fmt: skip

    def estimate_flips(self) -> tuple[int, int]:
        """Estimate every flip of the active rows and fly exactly those that can still win:
        how many, and their points."""
        return kernels.estimate_flips(
            self.active, self.rows, self.scores, self.sequences, self.level_at, self.sums,
            self.scene, self.last_flip, self.flights, self.flight_levels, self.estimate,
            self.unsure, self.task_row, self.task_start, self.row_tasks, self.flown,
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

    burning = np.zeros((1, *PAPER_MAP.shape), dtype=bool)
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
