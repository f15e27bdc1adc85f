"""The clairvoyant bound ``oracle``: the team planned on the fire's known future
(docs/model.md, Baselines).

The fire never depends on the aircraft, so an episode seed fixes its whole future
(``wildfire_sim.episode.FireEpisode`` steps the very fire the environment steps). And the
episode score is a space-time coverage count: a cell scores once, the first time an
aircraft visits it (centre within 100 m) at a decision when it burns, and never if it was
believed burning at the start (the ignition seed: such a cell is believed burning until
seen burnt out, and a burnt-out cell never burns again). A cell burns over one interval of
fire steps, so :func:`known_future` keeps per cell that interval, and the score of a team
flight is the number of scorable cells visited inside their interval
(:func:`coverage_score`, tested equal to the environment's score).

The search (:func:`plan_episode`) flies the team through the episode in receding horizon:
every ``replan_every`` decisions each aircraft in turn, given the others' current plans
(iterated best response), chooses ``horizon`` bank actions maximising the cells it newly
covers over the horizon, given everything the team has covered and the others' plans
cover. Each plan is a coordinate descent over single-action flips (first improvement,
passes until none improves) from several restarts: the previous plan shifted, hard left
and hard right circles, straight flight and random bank profiles. The search may score
only every ``sample_every``-th decision (coverage barely changes in 2 m of flight); the
flight it commits is flown and scored exactly. Flights use the project's dynamics float
for float (:func:`fly`, tested against ``wildfire_agent.dynamics.step``), so the plan the
environment flies scores exactly what :func:`plan_episode` predicts.

It is a bound to measure against, not a deployable controller: it reads the future. It
runs in ``wildfire eval`` and ``wildfire report`` only; an agent node refuses the name.

Every compiled function that calls another lives in this one file: numba's disk cache
(``cache=True``) checks only the source file of the function it compiled.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from wildfire_agent.dynamics import (
    BANK_STEP_RAD,
    DECISION_PERIOD_S,
    MAX_BANK_STEPS,
    SPEED_MPS,
    AircraftState,
    turn_rate,
)
from wildfire_agent.policy_names import EVAL_ONLY_POLICIES, ORACLE_POLICY
from wildfire_belief.visits import VISIT_RADIUS_M, WINDOW_HALF
from wildfire_learning.env import EnvConfig, WildfireVecEnv, draw_scenario
from wildfire_sim.episode import DECISIONS_PER_FIRE_STEP, FireEpisode
from wildfire_sim.grid import CELL_SIZE_M, GRID_SIZE
from wildfire_sim.seeding import Stream, generator

NEVER = np.iinfo(np.int64).max // 4
"""A fire step or decision that never comes."""

kernel = numba.njit(cache=True, nogil=True, error_model="numpy")
inlined = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

_RADIUS2 = VISIT_RADIUS_M**2
_LEVELS = 2 * MAX_BANK_STEPS + 1
_RATES = np.ascontiguousarray(
    turn_rate(np.arange(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1) * BANK_STEP_RAD), np.float64
)
"""Turn rate per bank level (row ``bank_steps + 10``), from numpy's tan as ``dynamics``."""


@dataclass(frozen=True)
class OracleConfig:
    """Search settings of the oracle (docs/model.md, Baselines: the clairvoyant bound)."""

    horizon: int = 200
    """T: decisions planned ahead."""
    replan_every: int = 10
    """tau: decisions flown between two plans."""
    random_restarts: int = 1
    """Random bank profiles besides the fixed restarts (previous plan, left, right, straight)."""
    max_passes: int = 3
    """Passes of coordinate descent per restart at most."""
    sample_every: int = 4
    """The search scores coverage every this many decisions (commits are exact)."""
    rounds: int = 1
    """Best-response rounds over the team per re-plan."""
    late_weight: float = 1.0
    """Worth, in the search, of a cell that burns on past ``urgent_window`` decisions from the
    plan's start (1: every new cell alike; below 1 favours the cells about to burn out)."""
    urgent_window: int = 400
    """See ``late_weight``."""


class KnownFuture(NamedTuple):
    """What an episode seed fixes, as the oracle reads it."""

    seed: int
    start: AircraftState
    """(N,) start poses."""
    decisions: int
    """Decisions the episode lasts (the fire alone decides)."""
    start_step: np.ndarray
    """(H * W,) int64: first fire step (0 = after the pre-burn) a scorable cell burns at;
    ``NEVER`` for cells that never burn in the flight or were believed burning at the start."""
    end_step: np.ndarray
    """(H * W,) int64: first fire step after ``start_step`` the cell no longer burns."""
    open_sums: np.ndarray
    """(S + 1, H + 1, W + 1) int64: per fire step, 2-D prefix sums of the scorable burning
    cells (to skip windows with none)."""

    @property
    def ceiling(self) -> int:
        """Cells a team could score at most (the environment's score ceiling)."""
        return int((self.start_step < NEVER).sum())


def known_future(seed: int, config: EnvConfig) -> KnownFuture:
    """The fire of episode ``seed`` over its whole flight, as intervals of fire steps."""
    scenario = draw_scenario(int(seed), config)
    episode = FireEpisode(
        int(seed),
        scenario.shape,
        (float(scenario.wind[0]), float(scenario.wind[1])),
        max_decisions=config.max_decisions,
        preburn_steps=config.preburn_steps,
        border_cells=config.border_cells,
        params=config.fire,
    )
    maps = [episode.burning.copy()]
    while not episode.final:
        if episode.advance():
            maps.append(episode.burning.copy())
    burning = np.stack(maps).reshape(len(maps), -1).astype(bool)
    scorable = ~episode.ignition_burning.reshape(-1).astype(bool)
    ever = burning.any(axis=0) & scorable
    start = np.where(ever, burning.argmax(axis=0), NEVER).astype(np.int64)
    end = np.where(ever, start + burning.sum(axis=0), NEVER).astype(np.int64)
    # A cell burns over one interval of fire steps (fuel only runs out): check it.
    steps = np.arange(len(maps))[:, None]
    if not np.array_equal((steps >= start) & (steps < end), burning & scorable):
        raise AssertionError(f"seed {seed}: a cell burns over two intervals")
    grid = (burning & scorable).reshape(len(maps), GRID_SIZE, GRID_SIZE).astype(np.int64)
    sums = np.zeros((len(maps), GRID_SIZE + 1, GRID_SIZE + 1), np.int64)
    sums[:, 1:, 1:] = grid.cumsum(axis=1).cumsum(axis=2)
    return KnownFuture(int(seed), scenario.start, episode.decisions, start, end, sums)


# ----------------------------------------------------------------------------- kernels
@inlined
def _fly_one(
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
def _fly(
    x: float, y: float, heading: float, level: int, actions: np.ndarray, rates: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """States (x, y, heading, level) after each action of ``actions``."""
    steps = actions.size
    xs, ys, hs = np.empty(steps), np.empty(steps), np.empty(steps)
    levels = np.empty(steps, np.int64)
    for t in range(steps):
        x, y, heading, level = _fly_one(x, y, heading, level, actions[t], rates)
        xs[t], ys[t], hs[t], levels[t] = x, y, heading, level
    return xs, ys, hs, levels


@inlined
def _window_has_open(sums: np.ndarray, step: int, row: int, col: int) -> bool:
    """Whether the visit window around cell (row, col) holds a scorable burning cell."""
    r0 = min(max(row - WINDOW_HALF, 0), GRID_SIZE)
    r1 = min(max(row + WINDOW_HALF + 1, 0), GRID_SIZE)
    c0 = min(max(col - WINDOW_HALF, 0), GRID_SIZE)
    c1 = min(max(col + WINDOW_HALF + 1, 0), GRID_SIZE)
    if r0 >= r1 or c0 >= c1:
        return False
    total = sums[step, r1, c1] - sums[step, r0, c1] - sums[step, r1, c0] + sums[step, r0, c0]
    return total > 0


@inlined
def _claim(
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
) -> float:
    """Visit the cells around (x, y) at fire step ``step`` (``visits.visit_windows``'s test,
    operation for operation): count the burning cells whose ``first`` is at least
    ``open_after`` and whose ``mark`` is not ``stamp``, and mark them (with ``stamp``, and
    ``first = write_first`` when ``write_first`` >= 0); returns their summed ``weight``."""
    row = math.floor(y / CELL_SIZE_M)
    col = math.floor(x / CELL_SIZE_M)
    count = 0.0
    for i in range(-WINDOW_HALF, WINDOW_HALF + 1):
        r = row + i
        if r < 0 or r >= GRID_SIZE:
            continue
        dy = (r + 0.5) * CELL_SIZE_M - y
        dy2 = dy * dy
        for j in range(-WINDOW_HALF, WINDOW_HALF + 1):
            c = col + j
            if c < 0 or c >= GRID_SIZE:
                continue
            dx = (c + 0.5) * CELL_SIZE_M - x
            if dy2 + dx * dx <= _RADIUS2:
                cell = r * GRID_SIZE + c
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
def _cover(
    xs: np.ndarray,
    ys: np.ndarray,
    first_decision: int,
    start: np.ndarray,
    end: np.ndarray,
    covered: np.ndarray,
) -> int:
    """Mark ``covered`` (0/1 per cell) the cells visited while burning by a flight whose
    point ``u`` is at decision ``first_decision + u``; returns the cells newly covered."""
    mark = np.zeros(covered.size, np.int64)
    first = np.zeros(covered.size, np.int64)
    for cell in range(covered.size):
        mark[cell] = 1 if covered[cell] else 0
    ones = np.ones(covered.size)
    count = 0
    for u in range(xs.size):
        step = (first_decision + u) // DECISIONS_PER_FIRE_STEP
        count += int(_claim(xs[u], ys[u], step, start, end, first, 0, mark, 1, -1, ones))
    for cell in range(covered.size):
        covered[cell] = mark[cell] == 1
    return count


@kernel
def _refresh(
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
        if not _window_has_open(
            sums, step, math.floor(ys[u] / CELL_SIZE_M), math.floor(xs[u] / CELL_SIZE_M)
        ):
            continue
        gain[u] = _claim(xs[u], ys[u], step, start, end, first, NEVER, mark, stamp, u, weight)


@kernel
def _search(
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
    best = restarts[0].copy()
    best_value = -1.0
    mark = np.zeros(cells, np.int64)
    stamp = 0
    gain = np.zeros(horizon)
    prefix = np.zeros(horizon + 1)
    for r in range(count):
        sequence = restarts[r].copy()
        xs, ys, hs, levels = _fly(x0, y0, h0, level0, sequence, rates)
        first = base_first.copy()
        stamp += 1
        _refresh(
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
                    x, y, heading, level = _fly_one(x, y, heading, level, action, rates)
                    decision = decision0 + u
                    if decision % sample_every != 0:
                        continue
                    step = decision // DECISIONS_PER_FIRE_STEP
                    if not _window_has_open(
                        sums, step, math.floor(y / CELL_SIZE_M), math.floor(x / CELL_SIZE_M)
                    ):
                        continue
                    total += _claim(x, y, step, start, end, first, t, mark, stamp, -1, weight)
                if total > value + 1e-9:
                    # Take the flip: fly it, forget what the plan covered from t on, re-credit.
                    sequence[t] ^= 1
                    fx, fy, fh, fl = _fly(
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
                    _refresh(
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


# ----------------------------------------------------------------------------- python side
def fly(state: AircraftState, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (x, y), each (N, L), of aircraft ``state`` (N,) flying ``actions`` (N, L):
    the floats ``dynamics.step`` gives, step after step (tested)."""
    actions = np.ascontiguousarray(actions, np.int64)
    xs = np.empty(actions.shape)
    ys = np.empty(actions.shape)
    for k in range(actions.shape[0]):
        x, y, _, _ = _fly(
            float(state.x_m[k]),
            float(state.y_m[k]),
            float(state.heading_rad[k]),
            int(state.bank_steps[k]),
            actions[k],
            _RATES,
        )
        xs[k], ys[k] = x, y
    return xs, ys


def coverage_score(future: KnownFuture, xs: np.ndarray, ys: np.ndarray) -> int:
    """Score of a team flight: positions (N, L) at decisions 1..L (L <= the episode's)."""
    covered = np.zeros(future.start_step.size, np.bool_)
    total = 0
    for k in range(xs.shape[0]):
        total += _cover(
            np.ascontiguousarray(xs[k], np.float64),
            np.ascontiguousarray(ys[k], np.float64),
            1,
            future.start_step,
            future.end_step,
            covered,
        )
    return total


def _hold(level: int, steps: int, target: int) -> np.ndarray:
    """Actions that bring the bank from ``level`` to ``target`` and hold it there (at the
    limit by pushing into it, elsewhere by alternating about it)."""
    actions = np.empty(steps, np.int64)
    for t in range(steps):
        if level < target:
            action = 1
        elif level > target:
            action = 0
        elif abs(target) == MAX_BANK_STEPS:
            action = 1 if target > 0 else 0
        else:
            action = 1 if t % 2 == 0 else 0
        actions[t] = action
        proposed = level + (1 if action else -1)
        level = proposed if abs(proposed) <= MAX_BANK_STEPS else level
    return actions


def _random_profile(rng: np.random.Generator, level: int, steps: int) -> np.ndarray:
    """Random bank levels held for random stretches of 1-4 s."""
    actions = np.empty(0, np.int64)
    while actions.size < steps:
        target = int(rng.integers(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1))
        stretch = int(rng.integers(10, 41))
        part = _hold(level, stretch, target)
        for a in part:
            proposed = level + (1 if a else -1)
            level = proposed if abs(proposed) <= MAX_BANK_STEPS else level
        actions = np.concatenate([actions, part])
    return actions[:steps]


def _level_after(level: int, actions: np.ndarray) -> int:
    for a in actions:
        proposed = level + (1 if a else -1)
        level = proposed if abs(proposed) <= MAX_BANK_STEPS else level
    return level


class OraclePlan(NamedTuple):
    """The oracle's flight of one episode."""

    actions: np.ndarray
    """(N, L) int64 bank actions of decisions 1..L."""
    score: int
    """Its score, as the oracle predicts it (the environment scores the same)."""
    x_m: np.ndarray
    """(N, L) predicted positions after each decision."""
    y_m: np.ndarray


def plan_episode(future: KnownFuture, config: OracleConfig | None = None) -> OraclePlan:
    """The oracle's flight of the episode ``future`` (see the module docstring)."""
    config = config or OracleConfig()
    start = future.start
    n = start.x_m.shape[0]
    length = future.decisions
    horizon, tau = config.horizon, config.replan_every
    cells = future.start_step.size
    rngs = [generator(future.seed, Stream.AIRCRAFT, k) for k in range(n)]
    # Plans run past the flight by a horizon so that shifted plans always have actions.
    plan = np.zeros((n, length + horizon + tau), np.int64)
    for k in range(n):
        plan[k] = _hold(int(start.bank_steps[k]), plan.shape[1], 0)
    state = [
        (float(start.x_m[k]), float(start.y_m[k]), float(start.heading_rad[k]),
         int(start.bank_steps[k]))
        for k in range(n)
    ]  # fmt: skip
    flown_x = np.empty((n, length))
    flown_y = np.empty((n, length))
    covered = np.zeros(cells, np.bool_)
    score = 0
    ss, es, sums = future.start_step, future.end_step, future.open_sums
    for d0 in range(0, length, tau):
        steps = min(horizon, length - d0)
        for _ in range(config.rounds):
            for k in range(n):
                others = np.zeros(cells, np.bool_)
                others[:] = covered
                for j in range(n):
                    if j != k:
                        x, y, _, _ = _fly(*state[j], plan[j, d0 : d0 + steps], _RATES)
                        _cover(x, y, d0 + 1, ss, es, others)
                base = np.where(others, -1, NEVER).astype(np.int64)
                late = es * DECISIONS_PER_FIRE_STEP > d0 + config.urgent_window
                weight = np.where(late, config.late_weight, 1.0)
                level = state[k][3]
                restarts = [
                    plan[k, d0 : d0 + steps].copy(),
                    _hold(level, steps, MAX_BANK_STEPS),
                    _hold(level, steps, -MAX_BANK_STEPS),
                    _hold(level, steps, 0),
                ]
                restarts += [
                    _random_profile(rngs[k], level, steps) for _ in range(config.random_restarts)
                ]
                best, _ = _search(
                    *state[k], d0 + 1, np.stack(restarts), base, weight, ss, es, sums, _RATES,
                    config.sample_every, config.max_passes,
                )  # fmt: skip
                plan[k, d0 : d0 + steps] = best
                # Past the horizon: hold the bank the plan ends on.
                tail = min(plan.shape[1] - (d0 + steps), horizon + tau)
                end_level = _level_after(level, best)
                plan[k, d0 + steps : d0 + steps + tail] = _hold(end_level, tail, end_level)
        # Commit the next tau decisions, flown and scored exactly.
        commit = min(tau, length - d0)
        for k in range(n):
            xs, ys, hs, levels = _fly(*state[k], plan[k, d0 : d0 + commit], _RATES)
            flown_x[k, d0 : d0 + commit], flown_y[k, d0 : d0 + commit] = xs, ys
            score += _cover(xs, ys, d0 + 1, ss, es, covered)
            state[k] = (float(xs[-1]), float(ys[-1]), float(hs[-1]), int(levels[-1]))
    return OraclePlan(plan[:, :length].copy(), score, flown_x, flown_y)


class OracleVecPolicy:
    """The oracle flying every aircraft of every episode of a vector environment: each
    episode is planned whole when it starts (its future is known), then replayed."""

    observation = "none"

    def __init__(self, config: OracleConfig | None = None) -> None:
        self.config = config or OracleConfig()
        self.plans: dict[int, OraclePlan] = {}
        self.plan_seconds: dict[int, float] = {}
        """Wall time of each episode's planning (in ``reset``, which ``evaluate`` does not
        time), by seed."""
        self._planned_seed: np.ndarray = np.zeros(0, np.int64)

    def _plan(self, env: WildfireVecEnv, e: int) -> None:
        seed = int(env.seeds[e])
        if seed not in self.plans:
            tic = time.perf_counter()
            self.plans[seed] = plan_episode(known_future(seed, env.config), self.config)
            self.plan_seconds[seed] = time.perf_counter() - tic
        self._planned_seed[e] = seed

    def reset(self, env: WildfireVecEnv) -> None:
        self._planned_seed = np.full(env.num_envs, -1, np.int64)
        for e in np.flatnonzero(~env.done).tolist():
            self._plan(env, e)

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        actions = np.zeros((env.num_envs, env.config.n_aircraft), np.int64)
        for e in np.flatnonzero(~env.done).tolist():
            if self._planned_seed.size != env.num_envs or self._planned_seed[e] != env.seeds[e]:
                if self._planned_seed.size != env.num_envs:
                    self._planned_seed = np.full(env.num_envs, -1, np.int64)
                self._plan(env, e)
            plan = self.plans[int(env.seeds[e])]
            decision = int(env.decisions[e])
            if decision < plan.actions.shape[1]:
                actions[e] = plan.actions[:, decision]
        return actions


__all__ = [
    "EVAL_ONLY_POLICIES",
    "NEVER",
    "ORACLE_POLICY",
    "KnownFuture",
    "OracleConfig",
    "OraclePlan",
    "OracleVecPolicy",
    "coverage_score",
    "fly",
    "known_future",
    "plan_episode",
]
