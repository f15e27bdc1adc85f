"""Receding-horizon baseline controller (docs/model.md, Baselines).

Every ``replan_every`` (tau) decisions, each aircraft plans on its own (not jointly) a
sequence of ``horizon`` (T) bank actions that maximises the summed observation-based reward
(``rewards.py``) on the **true** fire map held fixed, and then flies its first tau actions.

Two baselines differ only in the planner's model of the other aircraft
(``RecedingHorizonConfig.model_others``):

* ``rh`` (ours): the others are predicted to hold their current bank over the horizon, and the
  proximity term of the reward keeps the ownship's plan away from those predicted positions.
* ``rh-paper`` (the paper's baseline, "not coordinated, so the two aircraft fly near each
  other"): each aircraft plans as if it flew alone. Its model holds no other aircraft, so
  the proximity term, whose weight is unchanged, has nothing to act on. Holding the others
  at their current position instead was rejected: that is still a model of them, and its
  penalty would push the aircraft apart, which the paper's planner does not do.

Both keep the staggered re-planning (:func:`replan_phases`) and the same T, tau, restarts
and reward weights: the stagger only picks which decision a plan is computed at, so that the
team's plans do not all fall on one 100 ms period. It models no other aircraft.

Optimisation is coordinate descent from ``restarts`` random sequences: each sweep scores
every single-action flip of the current sequence and takes the best one while it improves
the score; the best local optimum over the restarts wins. All aircraft, restarts and flips
are scored together as one batch of trajectories. Two shortcuts keep every score the same
float as flying the sequence in full: a flip is scored from the decision it changes on (the
decisions before it are the unflipped sequence's), and a restart whose sweep found no
better flip is at its optimum for good, so it is not swept again.

Defaults: T = 60 (6 s ahead), tau = 10 (re-plan every second), 4 restarts. A 180 degree turn
at the bank limit takes 5.4 s, so shorter horizons cannot see that turning back towards the
fire pays (T = 30 scored ~8 % lower on seeds 100..105; T = 80, tau = 20 ~1 % higher at 25 %
more compute). A plan costs ~40 ms per aircraft on one core, i.e. ~4 ms per decision, well
inside the 100 ms of a decision (``wildfire bench`` reports it).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from wildfire_agent.dynamics import (
    BANK_STEP_RAD,
    DECISION_PERIOD_S,
    MAX_BANK_STEPS,
    SPEED_MPS,
    AircraftState,
    apply_action,
    constant_bank_track,
    turn_rate,
)
from wildfire_agent.rewards import (
    FireFieldMaps,
    ObservationRewardWeights,
    clear_count_map,
    fire_term_table,
    tabled_fire_terms,
)


@dataclass(frozen=True)
class RecedingHorizonConfig:
    """Planner settings."""

    horizon: int = 60
    """T: decisions planned ahead."""
    replan_every: int = 10
    """tau: decisions flown from a plan before re-planning (tau < T)."""
    restarts: int = 4
    """Random initial sequences per plan."""
    max_sweeps: int = 60
    """Safety bound on coordinate-descent sweeps per plan."""
    model_others: bool = True
    """Predict the other aircraft at constant bank in the proximity term (``rh``); False: each
    aircraft plans as if alone (``rh-paper``, see the module docstring)."""

    def __post_init__(self) -> None:
        if not 1 <= self.replan_every < self.horizon or self.restarts < 1:
            raise ValueError(
                "receding horizon: expected 1 <= replan_every < horizon and restarts >= 1, got "
                f"{self.replan_every}, {self.horizon}, {self.restarts}"
            )


def predict_constant_bank(others: AircraftState, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (x, y), each (..., steps), of aircraft holding their bank for ``steps``."""
    return constant_bank_track(others, steps)


_BANK_LEVELS = np.arange(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1)
_NEXT_LEVEL = (
    np.stack([apply_action(_BANK_LEVELS, np.full_like(_BANK_LEVELS, a)) for a in (0, 1)], axis=-1)
    + MAX_BANK_STEPS
)
"""Bank level (index bank_steps + 10) after each action (0, 1) from each level: ``apply_action``
as a table, one gather per decision where the planner walks thousands of sequences."""
_TURN_RATE = turn_rate(_BANK_LEVELS * BANK_STEP_RAD)
"""Heading rate of each bank level."""
# One decision on an arc of rate w and radius R = v / w, in the frame of the heading before
# it: A metres ahead and B metres to the left, A = R sin(w dt), B = R (1 - cos(w dt)).
# Wings level: A = v dt, B = 0. Then dx = A cos(psi) - B sin(psi), dy = A sin(psi) + B cos(psi).
_TURN_ANGLE = _TURN_RATE * DECISION_PERIOD_S
_SAFE_RATE = np.where(_BANK_LEVELS != 0, _TURN_RATE, 1.0)
_AHEAD_M = np.where(
    _BANK_LEVELS != 0, SPEED_MPS / _SAFE_RATE * np.sin(_TURN_ANGLE), SPEED_MPS * DECISION_PERIOD_S
)
_LEFT_M = np.where(_BANK_LEVELS != 0, SPEED_MPS / _SAFE_RATE * (1.0 - np.cos(_TURN_ANGLE)), 0.0)
_BANK_PENALTY_RAD2 = (_BANK_LEVELS * BANK_STEP_RAD) ** 2


def _bank_levels(start_level: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """Bank level after each action of ``actions`` (..., T) flown from ``start_level`` (...)."""
    levels = np.empty(actions.shape, dtype=np.int64)
    level = start_level
    for t in range(actions.shape[-1]):
        level = _NEXT_LEVEL[level, actions[..., t]]
        levels[..., t] = level
    return levels


def _headings_before(levels: np.ndarray, heading_rad: np.ndarray) -> np.ndarray:
    """Heading before each decision: the start heading, then after each turn but the last.

    One cumulative sum of per-level turn angles: no per-step heading wrap, ~10x faster than
    stepping ``dynamics.propagate`` and as accurate.
    """
    angle = _TURN_ANGLE[levels]
    return heading_rad + np.cumsum(angle, axis=-1) - angle


def _displacements(levels: np.ndarray, heading_before: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dx, dy) of each decision's exact arc, from the per-level arc tables."""
    sin_h, cos_h = np.sin(heading_before), np.cos(heading_before)
    ahead, left = _AHEAD_M[levels], _LEFT_M[levels]
    return ahead * cos_h - left * sin_h, ahead * sin_h + left * cos_h


class _Model(NamedTuple):
    """What a plan's rewards are scored against, one row per sequence being optimised."""

    own: AircraftState
    """Ownship fields, each (N, 1)."""
    env: np.ndarray
    """(N,) fire-map index."""
    others_x: np.ndarray
    """(N, K, T) predicted positions of the other aircraft."""
    others_y: np.ndarray
    table: np.ndarray
    """:func:`rewards.fire_term_table` of the fire maps."""
    maps: FireFieldMaps
    weights: ObservationRewardWeights

    def rows(self, index: np.ndarray) -> _Model:
        return self._replace(
            own=AircraftState(*(field[index] for field in self.own)),
            env=self.env[index],
            others_x=self.others_x[index],
            others_y=self.others_y[index],
        )


def _step_rewards(
    model: _Model, levels: np.ndarray, x: np.ndarray, y: np.ndarray, steps: np.ndarray | slice
) -> np.ndarray:
    """Reward of each decision at positions (x, y) (N, S), decisions ``steps`` of the horizon."""
    weights = model.weights
    env = np.broadcast_to(model.env[:, None], x.shape)
    reward = tabled_fire_terms(model.table, model.maps, env, x, y, weights)
    reward -= weights.bank * _BANK_PENALTY_RAD2[levels]
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


def _fly(model: _Model, actions: np.ndarray) -> _Flown:
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


def _flip_scores(model: _Model, actions: np.ndarray, flown: _Flown) -> np.ndarray:
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


def _model(
    own: AircraftState,
    env: np.ndarray,
    maps: FireFieldMaps,
    others_xy: tuple[np.ndarray, np.ndarray],
    weights: ObservationRewardWeights,
) -> _Model:
    if maps.clear_count is None:
        # Thousands of positions get scored: read r2 from the disc-count map.
        maps = maps._replace(clear_count=clear_count_map(maps.burning, weights.clear_radius_m))
    return _Model(
        own=AircraftState(*(np.asarray(field)[:, None] for field in own)),
        env=np.asarray(env, dtype=np.int64),
        others_x=others_xy[0],
        others_y=others_xy[1],
        table=fire_term_table(maps, weights),
        maps=maps,
        weights=weights,
    )


def score_sequences(
    actions: np.ndarray,
    own: AircraftState,
    env: np.ndarray,
    maps: FireFieldMaps,
    others_xy: tuple[np.ndarray, np.ndarray],
    weights: ObservationRewardWeights,
) -> np.ndarray:
    """Summed reward (P,) of one action sequence per aircraft, ``actions`` (P, T), flown from
    ``own`` (P,); ``others_xy`` are the other aircraft's predicted positions, each (P, K, T).

    The trajectory is this planner's model of the dynamics: the same exact arcs as
    ``dynamics.propagate``, integrated for all T steps at once.
    """
    return _fly(_model(own, env, maps, others_xy, weights), np.asarray(actions, np.int64)).score


def plan(
    own: AircraftState,
    others: AircraftState,
    env: np.ndarray,
    maps: FireFieldMaps,
    generators: list[np.random.Generator],
    config: RecedingHorizonConfig,
    weights: ObservationRewardWeights,
) -> np.ndarray:
    """Best action sequence (P, T) for each of P aircraft ``own`` (fields (P,)).

    ``others`` has fields (P, K); ``env`` (P,) selects each aircraft's fire maps;
    ``generators[p]`` draws aircraft p's random restarts.
    """
    horizon, restarts, count = config.horizon, config.restarts, len(generators)
    if config.model_others:
        others_xy = predict_constant_bank(others, horizon)
    else:
        # Planning alone: no other aircraft in the model, so no proximity penalty.
        nobody = np.zeros((count, 0, horizon))
        others_xy = (nobody, nobody)
    # One row per (aircraft, restart).
    model = _model(own, env, maps, others_xy, weights).rows(np.repeat(np.arange(count), restarts))
    sequences = np.concatenate(
        [rng.integers(0, 2, size=(restarts, horizon)) for rng in generators]
    ).astype(np.int64)
    flown = _fly(model, sequences)
    scores = flown.score
    # Rows whose last sweep found no better flip are at their local optimum for good: only
    # the others are swept again.
    active = np.arange(len(sequences))
    for _ in range(config.max_sweeps):
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
    winner = scores.reshape(count, restarts).argmax(axis=-1)
    return sequences.reshape(count, restarts, horizon)[np.arange(count), winner]


def replan_phases(aircraft: np.ndarray, n_aircraft: int, replan_every: int) -> np.ndarray:
    """Decisions by which each aircraft's re-planning is staggered: ``k * tau // n``.

    Everyone plans at decision 0; aircraft k then flies only ``tau - phase_k`` decisions of
    its first plan, so later plans of a team are spread over the tau decisions instead of
    all falling on the same one (8 aircraft re-planning on the same tick would need 8 plans
    within one 100 ms period on 2 cores).
    """
    return (np.asarray(aircraft, dtype=np.int64) * replan_every) // n_aircraft


class RecedingHorizonController:
    """Plans every tau decisions and flies the plan in between, for P aircraft at once.

    ``phases`` (P,) staggers the aircraft (see :func:`replan_phases`); each aircraft plans
    from its own generator, so its plans do not depend on which others plan with it.
    """

    def __init__(
        self,
        generators: list[np.random.Generator],
        config: RecedingHorizonConfig | None = None,
        weights: ObservationRewardWeights | None = None,
        phases: np.ndarray | None = None,
    ) -> None:
        self.generators = generators
        self.config = config or RecedingHorizonConfig()
        self.weights = weights or ObservationRewardWeights()
        count = len(generators)
        self._plans = np.zeros((count, self.config.horizon), dtype=np.int64)
        # Decisions flown from the current plan, and how many to fly before re-planning.
        self._flown = np.zeros(count, dtype=np.int64)
        phases = np.zeros(count, np.int64) if phases is None else np.asarray(phases, np.int64)
        self._segment = self.config.replan_every - phases % self.config.replan_every
        self._planned = False

    def act(
        self, own: AircraftState, others: AircraftState, env: np.ndarray, maps: FireFieldMaps
    ) -> np.ndarray:
        """Actions (P,) of the aircraft ``own`` (fields (P,)); others' fields are (P, K)."""
        due = (
            np.ones(len(self.generators), bool)
            if not self._planned
            else (self._flown >= self._segment)
        )
        if due.any():
            index = np.flatnonzero(due)
            self._plans[index] = plan(
                AircraftState(*(field[index] for field in own)),
                AircraftState(*(field[index] for field in others)),
                env[index],
                maps,
                [self.generators[i] for i in index.tolist()],
                self.config,
                self.weights,
            )
            if self._planned:
                self._segment[index] = self.config.replan_every
            self._flown[index] = 0
            self._planned = True
        action = self._plans[np.arange(len(self.generators)), self._flown]
        self._flown += 1
        return action


__all__ = [
    "RecedingHorizonConfig",
    "RecedingHorizonController",
    "plan",
    "predict_constant_bank",
    "replan_phases",
    "score_sequences",
]
