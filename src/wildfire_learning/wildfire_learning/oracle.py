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

The plan flown (``oracle_policy.OracleVecPolicy``) is the best team flight found: the
search's own, or an incumbent's, the flight of a shipped policy on the same episode
(``oracle_incumbents.flight_of``) if one scores more, then refined with the known future
(:func:`refine`: whole-episode iterated best response, each aircraft re-planned in receding
horizon against the others' whole flights, kept only if the team scores more).

It is a bound to measure against, not a deployable controller: it reads the future. It
runs in ``wildfire eval`` and ``wildfire report`` only; an agent node refuses the name.

The compiled kernels (flight, visit test, coordinate descent) are in
:mod:`wildfire_learning.oracle_kernels`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from wildfire_agent.dynamics import MAX_BANK_STEPS, AircraftState
from wildfire_learning.oracle_incumbents import INCUMBENT_POLICIES
from wildfire_learning.oracle_kernels import NEVER, RATES, cover, fly_path, search
from wildfire_sim.episode import DECISIONS_PER_FIRE_STEP, FireEpisode
from wildfire_sim.seeding import Stream, generator
from wildfire_world.env import EnvConfig, draw_scenario


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
    incumbents: tuple[str, ...] = INCUMBENT_POLICIES
    """Policies whose flight of the same episode is an incumbent (the best-scoring one, or
    the search's own plan if better, is refined); ``()`` measures the search alone."""
    refine_horizons: tuple[int, ...] = (20, 30, 50)
    """The T of the receding horizons that re-plan one aircraft against the others' whole
    flights, tried in turn."""
    refine_rounds: int = 10
    """Passes over the moves (every aircraft at every ``refine_horizons``) at most."""
    time_budget_s: float = 50.0
    """No further best response starts past this much planning time of an episode (only
    then may two runs differ)."""


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
    def cols(self) -> int:
        """Cells of the map from west to east."""
        return self.open_sums.shape[2] - 1

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
        ground=config.ground,
        preburn_area_m2=config.preburn_area_m2,
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
    rows, cols = config.geometry.shape
    grid = (burning & scorable).reshape(len(maps), rows, cols).astype(np.int64)
    sums = np.zeros((len(maps), rows + 1, cols + 1), np.int64)
    sums[:, 1:, 1:] = grid.cumsum(axis=1).cumsum(axis=2)
    return KnownFuture(int(seed), scenario.start, episode.decisions, start, end, sums)


def fly(state: AircraftState, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (x, y), each (N, L), of aircraft ``state`` (N,) flying ``actions`` (N, L):
    the floats ``dynamics.step`` gives, step after step (tested)."""
    actions = np.ascontiguousarray(actions, np.int64)
    xs = np.empty(actions.shape)
    ys = np.empty(actions.shape)
    for k in range(actions.shape[0]):
        x, y, _, _ = fly_path(
            float(state.x_m[k]),
            float(state.y_m[k]),
            float(state.heading_rad[k]),
            int(state.bank_steps[k]),
            actions[k],
            RATES,
        )
        xs[k], ys[k] = x, y
    return xs, ys


def coverage_score(future: KnownFuture, xs: np.ndarray, ys: np.ndarray) -> int:
    """Score of a team flight: positions (N, L) at decisions 1..L (L <= the episode's)."""
    covered = np.zeros(future.start_step.size, np.bool_)
    total = 0
    for k in range(xs.shape[0]):
        total += cover(
            np.ascontiguousarray(xs[k], np.float64),
            np.ascontiguousarray(ys[k], np.float64),
            1,
            future.start_step,
            future.end_step,
            covered,
            future.cols,
        )
    return total


def _next_level(level: int, action: int) -> int:
    """``dynamics.apply_action`` of one aircraft's bank level, as a plain int (the planning
    loops below call it per decision, where a numpy call each time would cost more)."""
    proposed = level + (1 if action else -1)
    return proposed if abs(proposed) <= MAX_BANK_STEPS else level


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
        level = _next_level(level, action)
    return actions


def _random_profile(rng: np.random.Generator, level: int, steps: int) -> np.ndarray:
    """Random bank levels held for random stretches of 1-4 s."""
    actions = np.empty(0, np.int64)
    while actions.size < steps:
        target = int(rng.integers(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1))
        stretch = int(rng.integers(10, 41))
        part = _hold(level, stretch, target)
        level = _level_after(level, part)
        actions = np.concatenate([actions, part])
    return actions[:steps]


def _level_after(level: int, actions: np.ndarray) -> int:
    """The bank level after flying ``actions`` from ``level``."""
    for action in actions.tolist():
        level = _next_level(level, action)
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


Pose = tuple[float, float, float, int]
"""One aircraft as the compiled kernels take it: x, y, heading, bank level."""


def poses(state: AircraftState, aircraft: list[int]) -> dict[int, Pose]:
    """The kernels' poses of ``aircraft`` of the team ``state`` (N,)."""
    return {
        k: (float(state.x_m[k]), float(state.y_m[k]), float(state.heading_rad[k]),
            int(state.bank_steps[k]))
        for k in aircraft
    }  # fmt: skip


def replan_team(
    future: KnownFuture,
    config: OracleConfig,
    plan: np.ndarray,
    state: dict[int, Pose],
    free: list[int],
    covered: np.ndarray,
    d0: int,
    horizon: int,
    rngs: dict[int, np.random.Generator],
    keep_tail: bool = False,
) -> None:
    """One re-plan at decision ``d0`` (``d0`` decisions flown, aircraft ``free`` at poses
    ``state``): each of them in turn, for ``config.rounds`` rounds, chooses the next
    ``horizon`` actions of its row of ``plan`` (N, >= d0 + horizon + tau) maximising the cells
    it newly covers, given ``covered`` (H * W,) and the others' rows (iterated best response).
    Past a plan's horizon the bank it ends on is held, or with ``keep_tail`` the actions kept.
    The oracle's own search and the oracle teacher (``teacher.py``) both plan with it."""
    steps = min(horizon, future.decisions - d0)
    ss, es, sums = future.start_step, future.end_step, future.open_sums
    for _ in range(config.rounds):
        for k in free:
            others = covered.copy()
            for j in free:
                if j != k:
                    x, y, _, _ = fly_path(*state[j], plan[j, d0 : d0 + steps], RATES)
                    cover(x, y, d0 + 1, ss, es, others, future.cols)
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
            best, _ = search(
                *state[k], d0 + 1, np.stack(restarts), base, weight, ss, es, sums, RATES,
                config.sample_every, config.max_passes,
            )  # fmt: skip
            plan[k, d0 : d0 + steps] = best
            if keep_tail:
                continue
            # Past the horizon: hold the bank the plan ends on.
            tail = min(plan.shape[1] - (d0 + steps), horizon + config.replan_every)
            end_level = _level_after(level, best)
            plan[k, d0 + steps : d0 + steps + tail] = _hold(end_level, tail, end_level)


def _receding_horizon(
    future: KnownFuture,
    config: OracleConfig,
    plan: np.ndarray,
    free: list[int],
    covered: np.ndarray,
    horizon: int,
    keep_tail: bool = False,
) -> np.ndarray:
    """Re-plan aircraft ``free`` of ``plan`` (N, L + horizon + tau; their rows start as the
    plans the search shifts) in receding horizon, the cells of ``covered`` (the fixed
    aircraft's whole flights) counted as covered; returns the (N, L) actions flown. Past a
    plan's horizon the bank it ends on is held, or with ``keep_tail`` the actions kept."""
    length = future.decisions
    tau = config.replan_every
    rngs = {k: generator(future.seed, Stream.AIRCRAFT, k) for k in free}
    state = poses(future.start, free)
    for d0 in range(0, length, tau):
        replan_team(future, config, plan, state, free, covered, d0, horizon, rngs, keep_tail)
        # Commit the next tau decisions, flown and scored exactly.
        commit = min(tau, length - d0)
        for k in free:
            xs, ys, hs, levels = fly_path(*state[k], plan[k, d0 : d0 + commit], RATES)
            cover(xs, ys, d0 + 1, future.start_step, future.end_step, covered, future.cols)
            state[k] = (float(xs[-1]), float(ys[-1]), float(hs[-1]), int(levels[-1]))
    return plan[:, :length].copy()


def as_plan(future: KnownFuture, actions: np.ndarray) -> OraclePlan:
    """The team flight ``actions`` (N, L), flown and scored exactly."""
    actions = np.ascontiguousarray(actions, np.int64)
    xs, ys = fly(future.start, actions)
    return OraclePlan(actions, coverage_score(future, xs, ys), xs, ys)


def _padded(future: KnownFuture, actions: np.ndarray, pad: int) -> np.ndarray:
    """``actions`` (N, L) extended by ``pad`` decisions holding the bank each ends on."""
    n, length = actions.shape
    plan = np.zeros((n, length + pad), np.int64)
    for k in range(n):
        level = int(future.start.bank_steps[k])
        plan[k, :length] = actions[k]
        end = _level_after(level, actions[k])
        plan[k, length:] = _hold(end, pad, end)
    return plan


def first_plan(future: KnownFuture, config: OracleConfig) -> np.ndarray:
    """(N, decisions + T + tau): the plan the search starts from, every aircraft levelling
    its wings and flying straight."""
    length = future.decisions + config.horizon + config.replan_every
    return np.stack([_hold(int(bank), length, 0) for bank in future.start.bank_steps.tolist()])


def plan_episode(future: KnownFuture, config: OracleConfig | None = None) -> OraclePlan:
    """The search's own flight of the episode ``future`` (see the module docstring)."""
    config = config or OracleConfig()
    n = future.start.x_m.shape[0]
    plan = first_plan(future, config)
    covered = np.zeros(future.start_step.size, np.bool_)
    actions = _receding_horizon(future, config, plan, list(range(n)), covered, config.horizon)
    return as_plan(future, actions)


def best_response(
    future: KnownFuture, team: OraclePlan, k: int, horizon: int, config: OracleConfig
) -> OraclePlan:
    """``team`` with aircraft ``k``'s whole flight re-planned in receding horizon (T =
    ``horizon``, its own flight the plan it starts from) against the others' whole flights."""
    n = future.start.x_m.shape[0]
    covered = np.zeros(future.start_step.size, np.bool_)
    for j in range(n):
        if j != k:
            cover(
                team.x_m[j], team.y_m[j], 1, future.start_step, future.end_step, covered,
                future.cols,
            )  # fmt: skip
    plan = _padded(future, team.actions, horizon + config.replan_every)
    actions = _receding_horizon(future, config, plan, [k], covered, horizon, keep_tail=True)
    others = np.arange(n) != k
    actions[others] = team.actions[others]
    return as_plan(future, actions)


def refine(
    future: KnownFuture,
    incumbent: OraclePlan,
    config: OracleConfig | None = None,
    deadline: float = math.inf,
) -> OraclePlan:
    """Whole-episode iterated best response from ``incumbent``: aircraft by aircraft, for
    each horizon of ``refine_horizons`` in turn, re-plan one aircraft's whole flight against
    the others' (:func:`best_response`) and keep the new team flight only if it scores more.
    Stops when no move gains any more, after ``refine_rounds`` passes over the moves, or at
    ``deadline`` (``time.perf_counter``) between two moves."""
    config = config or OracleConfig()
    n = future.start.x_m.shape[0]
    moves = [(horizon, k) for horizon in config.refine_horizons for k in range(n)]
    best = incumbent
    stale = 0
    for move in range(config.refine_rounds * len(moves)):
        if stale >= len(moves) or time.perf_counter() >= deadline:
            break
        horizon, k = moves[move % len(moves)]
        candidate = best_response(future, best, k, horizon, config)
        if candidate.score > best.score:
            best, stale = candidate, 0
        else:
            stale += 1
    return best


__all__ = [
    "KnownFuture",
    "OracleConfig",
    "OraclePlan",
    "as_plan",
    "coverage_score",
    "first_plan",
    "fly",
    "known_future",
    "plan_episode",
    "poses",
    "refine",
    "replan_team",
]
