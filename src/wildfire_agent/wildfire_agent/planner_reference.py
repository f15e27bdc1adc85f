"""The receding-horizon planner's search in numpy: the reference the compiled one must equal.

One search of :func:`search` improves a batch of action sequences (one row per aircraft and
restart) by coordinate descent: each sweep scores every single-action flip of the current
sequences and takes the best one while it improves the score. All rows and flips are scored
together as one batch of trajectories. Two shortcuts keep every score the same float as
flying the sequence in full: a flip is scored from the decision it changes on (the decisions
before it are the unflipped sequence's), and a row whose sweep found no better flip is at
its optimum for good, so it is not swept again.

:mod:`wildfire_agent.planner_compiled` runs the same search as compiled loops, ~10x cheaper;
this module stays as the readable definition of every float it must reproduce (tests and
``wildfire bench --only rh`` compare the two).
"""

from __future__ import annotations

import functools
from collections import OrderedDict
from typing import NamedTuple

import numpy as np

from wildfire_agent.dynamics import (
    BANK_STEP_RAD,
    DECISION_PERIOD_S,
    MAX_BANK_STEPS,
    SPEED_MPS,
    AircraftState,
    apply_action,
    turn_rate,
)
from wildfire_agent.rewards import (
    FireFieldMaps,
    ObservationRewardWeights,
    clear_count_map,
    fire_term_table,
    tabled_fire_terms,
)

BANK_LEVELS = np.arange(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1)
"""Bank levels: index ``bank_steps + MAX_BANK_STEPS`` of the per-level tables below."""
NEXT_LEVEL = (
    np.stack([apply_action(BANK_LEVELS, np.full_like(BANK_LEVELS, a)) for a in (0, 1)], axis=-1)
    + MAX_BANK_STEPS
)
"""Bank level after each action (0, 1) from each level: ``apply_action`` as a table, one
gather per decision where the planner walks thousands of sequences."""
_TURN_RATE = turn_rate(BANK_LEVELS * BANK_STEP_RAD)
# One decision on an arc of rate w and radius R = v / w, in the frame of the heading before
# it: A metres ahead and B metres to the left, A = R sin(w dt), B = R (1 - cos(w dt)).
# Wings level: A = v dt, B = 0. Then dx = A cos(psi) - B sin(psi), dy = A sin(psi) + B cos(psi).
TURN_ANGLE = _TURN_RATE * DECISION_PERIOD_S
"""Heading change of one decision at each bank level."""
_SAFE_RATE = np.where(BANK_LEVELS != 0, _TURN_RATE, 1.0)
AHEAD_M = np.where(
    BANK_LEVELS != 0, SPEED_MPS / _SAFE_RATE * np.sin(TURN_ANGLE), SPEED_MPS * DECISION_PERIOD_S
)
"""A: metres flown along the heading before the decision, per bank level."""
LEFT_M = np.where(BANK_LEVELS != 0, SPEED_MPS / _SAFE_RATE * (1.0 - np.cos(TURN_ANGLE)), 0.0)
"""B: metres flown to the left of that heading, per bank level."""
BANK_PENALTY_RAD2 = (BANK_LEVELS * BANK_STEP_RAD) ** 2
"""phi^2 of each bank level (the r3 term before its weight)."""


def _bank_levels(start_level: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """Bank level after each action of ``actions`` (..., T) flown from ``start_level`` (...)."""
    levels = np.empty(actions.shape, dtype=np.int64)
    level = start_level
    for t in range(actions.shape[-1]):
        level = NEXT_LEVEL[level, actions[..., t]]
        levels[..., t] = level
    return levels


def _headings_before(levels: np.ndarray, heading_rad: np.ndarray) -> np.ndarray:
    """Heading before each decision: the start heading, then after each turn but the last.

    One cumulative sum of per-level turn angles: no per-step heading wrap, ~10x faster than
    stepping ``dynamics.propagate`` and as accurate.
    """
    angle = TURN_ANGLE[levels]
    return heading_rad + np.cumsum(angle, axis=-1) - angle


def _displacements(levels: np.ndarray, heading_before: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dx, dy) of each decision's exact arc, from the per-level arc tables."""
    sin_h, cos_h = np.sin(heading_before), np.cos(heading_before)
    ahead, left = AHEAD_M[levels], LEFT_M[levels]
    return ahead * cos_h - left * sin_h, ahead * sin_h + left * cos_h


class PlanModel(NamedTuple):
    """What a plan's rewards are scored against, one row per sequence being optimised."""

    own: AircraftState
    """Ownship fields, each (N, 1)."""
    env: np.ndarray
    """(N,) index into the rows of ``table`` and ``maps``."""
    others_x: np.ndarray
    """(N, K, T) predicted positions of the other aircraft."""
    others_y: np.ndarray
    table: np.ndarray
    """:func:`rewards.fire_term_table` of the fire maps."""
    maps: FireFieldMaps
    """The fire maps, with their disc-count map (``clear_count``)."""
    weights: ObservationRewardWeights

    def rows(self, index: np.ndarray) -> PlanModel:
        return self._replace(
            own=AircraftState(*(field[index] for field in self.own)),
            env=self.env[index],
            others_x=self.others_x[index],
            others_y=self.others_y[index],
        )


class _Lookups(NamedTuple):
    """The planner's look-ups of one fire map, and the distance map they were made from."""

    distance_m: np.ndarray
    clear_count: np.ndarray
    table: np.ndarray


_LOOKUPS: OrderedDict[tuple[ObservationRewardWeights, bytes], _Lookups] = OrderedDict()
_LOOKUPS_KEPT = 32
"""Fire maps whose look-ups are kept: a fire map serves 25 decisions of re-planning, and a
batch of evaluation environments plans on one map each."""


def _lookups(
    burning: np.ndarray, distance_m: np.ndarray, weights: ObservationRewardWeights
) -> _Lookups:
    """Disc-count map and fire-term table of one (H, W) fire map, computed once per map.

    Kept by content (the burning cells, then the distance map compared in full), not by
    identity: callers update their maps in place between fire steps.
    """
    key = (weights, np.packbits(burning).tobytes())
    kept = _LOOKUPS.get(key)
    if kept is not None and np.array_equal(kept.distance_m, distance_m):
        _LOOKUPS.move_to_end(key)
        return kept
    clear = clear_count_map(burning[None], weights.clear_radius_m)
    maps = FireFieldMaps(burning=burning[None], distance_m=distance_m[None], clear_count=clear)
    kept = _Lookups(distance_m.copy(), clear[0], fire_term_table(maps, weights)[0])
    _LOOKUPS[key] = kept
    while len(_LOOKUPS) > _LOOKUPS_KEPT:
        _LOOKUPS.popitem(last=False)
    return kept


def plan_model(
    own: AircraftState,
    env: np.ndarray,
    maps: FireFieldMaps,
    others_xy: tuple[np.ndarray, np.ndarray],
    weights: ObservationRewardWeights,
) -> PlanModel:
    """The model of P aircraft ``own`` (fields (P,)) flying in fire maps ``env`` (P,).

    Only the environments the aircraft fly in get look-ups (thousands of positions get
    scored: r2 is read from a disc-count map, r1 + r2 from a table), and ``env`` is
    renumbered into them.
    """
    used, env = np.unique(np.asarray(env, dtype=np.int64), return_inverse=True)
    lookups = [_lookups(maps.burning[e], maps.distance_m[e], weights) for e in used.tolist()]

    def stacked(field: int) -> np.ndarray:
        # One map (an agent node, a lone episode) needs no copy.
        arrays = [kept[field] for kept in lookups]
        return arrays[0][None] if len(arrays) == 1 else np.stack(arrays)

    return PlanModel(
        own=AircraftState(*(np.asarray(field)[:, None] for field in own)),
        env=env.reshape(-1).astype(np.int64),
        others_x=others_xy[0],
        others_y=others_xy[1],
        table=stacked(2),
        maps=FireFieldMaps(
            burning=maps.burning[used], distance_m=stacked(0), clear_count=stacked(1)
        ),
        weights=weights,
    )


def _step_rewards(
    model: PlanModel, levels: np.ndarray, x: np.ndarray, y: np.ndarray, steps: np.ndarray | slice
) -> np.ndarray:
    """Reward of each decision at positions (x, y) (N, S), decisions ``steps`` of the horizon."""
    weights = model.weights
    env = np.broadcast_to(model.env[:, None], x.shape)
    reward = tabled_fire_terms(model.table, model.maps, env, x, y, weights)
    reward -= weights.bank * BANK_PENALTY_RAD2[levels]
    for k in range(model.others_x.shape[1]):
        distance = np.hypot(x - model.others_x[:, k, steps], y - model.others_y[:, k, steps])
        reward -= weights.proximity * np.exp(-distance / weights.proximity_scale_m)
    return reward


class _Flown(NamedTuple):
    """Per-decision pieces of a batch of sequences, (N, T) each."""

    dx: np.ndarray
    dy: np.ndarray
    reward: np.ndarray
    score: np.ndarray
    """(N,) summed reward."""


def _fly(model: PlanModel, actions: np.ndarray) -> _Flown:
    """Fly and score one sequence ``actions`` (N, T) per row of ``model``."""
    own = model.own
    levels = _bank_levels(own.bank_steps[:, 0] + MAX_BANK_STEPS, actions)
    dx, dy = _displacements(levels, _headings_before(levels, own.heading_rad))
    x = own.x_m + np.cumsum(dx, axis=-1)
    y = own.y_m + np.cumsum(dy, axis=-1)
    reward = _step_rewards(model, levels, x, y, slice(None))
    # A sequential sum (cumsum), so the total never depends on the batch's memory layout.
    return _Flown(dx, dy, reward, np.cumsum(reward, axis=-1)[:, -1])


@functools.lru_cache(maxsize=4)
def _suffix(horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """(flip, step) index pairs with step >= flip: the decisions a single flip can change."""
    flips, steps = np.nonzero(np.triu(np.ones((horizon, horizon), dtype=bool)))
    return flips, steps


def flip_scores(model: PlanModel, actions: np.ndarray) -> np.ndarray:
    """Score (N, T) of each single-action flip of the sequences ``actions`` (N, T)."""
    return _flip_scores(model, actions, _fly(model, actions))


def _flip_scores(model: PlanModel, actions: np.ndarray, flown: _Flown) -> np.ndarray:
    """Score (N, T) of each single-action flip of the sequences ``actions`` (N, T).

    Flipping action j changes nothing before decision j, so the trigonometry, the fire
    look-ups and the proximity terms are computed only on or after each flip (about half of
    the N x T x T decisions), and the decisions before it are copied from the unflipped
    ``flown``. Positions and scores still come from cumulative sums over whole sequences,
    whose first j partial sums are exactly the unflipped sequence's: every flip scores the
    same float as flying the flipped sequence in full (:func:`score_sequences`).
    """
    horizon = actions.shape[-1]
    flips, steps = _suffix(horizon)
    own = model.own
    candidates = actions[:, None, :] ^ np.eye(horizon, dtype=actions.dtype)  # (N, T flips, T)
    levels = _bank_levels(own.bank_steps + MAX_BANK_STEPS, candidates)
    heading = _headings_before(levels, own.heading_rad[:, :, None])
    changed = levels[:, flips, steps]
    dx = np.repeat(flown.dx[:, None, :], horizon, axis=1)
    dy = np.repeat(flown.dy[:, None, :], horizon, axis=1)
    dx[:, flips, steps], dy[:, flips, steps] = _displacements(changed, heading[:, flips, steps])
    x = own.x_m[:, :, None] + np.cumsum(dx, axis=-1)
    y = own.y_m[:, :, None] + np.cumsum(dy, axis=-1)
    reward = np.repeat(flown.reward[:, None, :], horizon, axis=1)
    reward[:, flips, steps] = _step_rewards(
        model, changed, x[:, flips, steps], y[:, flips, steps], steps
    )
    return np.cumsum(reward, axis=-1)[..., -1]


def score_sequences(model: PlanModel, actions: np.ndarray) -> np.ndarray:
    """Summed reward (N,) of one action sequence per row of ``model``, ``actions`` (N, T).

    The trajectory is the planner's model of the dynamics: the same exact arcs as
    ``dynamics.propagate``, integrated for all T steps at once.
    """
    return _fly(model, np.asarray(actions, np.int64)).score


def search(
    model: PlanModel, sequences: np.ndarray, max_sweeps: int
) -> tuple[np.ndarray, np.ndarray]:
    """Coordinate descent from ``sequences`` (N, T), one per row of ``model``.

    Returns the local optima (N, T) and their scores (N,).
    """
    sequences = np.array(sequences, dtype=np.int64)
    flown = _fly(model, sequences)
    scores = flown.score
    # Rows whose last sweep found no better flip are at their local optimum for good: only
    # the others are swept again.
    active = np.arange(len(sequences))
    for _ in range(max_sweeps):
        candidate_scores = _flip_scores(model.rows(active), sequences[active], flown)
        best = candidate_scores.argmax(axis=-1)
        best_score = candidate_scores[np.arange(len(active)), best]
        improves = best_score > scores[active]
        if not improves.any():
            break
        active, best = active[improves], best[improves]
        sequences[active, best] ^= 1
        scores[active] = best_score[improves]
        flown = _fly(model.rows(active), sequences[active])
    return sequences, scores


__all__ = [
    "AHEAD_M",
    "BANK_LEVELS",
    "BANK_PENALTY_RAD2",
    "LEFT_M",
    "NEXT_LEVEL",
    "TURN_ANGLE",
    "PlanModel",
    "flip_scores",
    "plan_model",
    "score_sequences",
    "search",
]
