"""Receding-horizon baseline policy (docs/model.md, Baselines).

Every ``replan_every`` (tau) decisions, each aircraft plans on its own (not jointly) a
sequence of ``horizon`` (T) bank actions that maximises the summed observation-based reward
(``rewards.py``) on the **true** fire map held fixed, and then flies its first tau actions.

Three baselines differ only in the planner's model of the other aircraft
(``RecedingHorizonConfig.model_others``) and in the map it plans on
(``RecedingHorizonConfig.believed_map``):

* ``rh`` (ours): the others are predicted to hold their current bank over the horizon, and the
  proximity term of the reward keeps the ownship's plan away from those predicted positions.
* ``rh-paper`` (the paper's baseline, "not coordinated, so the two aircraft fly near each
  other"): each aircraft plans as if it flew alone. Its model holds no other aircraft, so
  the proximity term, whose weight is unchanged, has nothing to act on. Holding the others
  at their current position instead was rejected: that is still a model of them, and its
  penalty would push the aircraft apart, which the paper's planner does not do.
* ``rh-belief`` (the fair baseline): ``rh`` planning on the team's *believed* map (the
  shared belief, or under limited radio links the aircraft's own replica) instead of the
  truth, which no real aircraft has. The learned policies see only what the team believes;
  ``rh`` is privileged, ``rh-belief`` is not.

Both keep the staggered re-planning (:func:`replan_phases`) and the same T, tau, restarts
and reward weights: the stagger only picks which decision a plan is computed at, so that the
team's plans do not all fall on one 100 ms period. It models no other aircraft.

Optimisation is coordinate descent from ``restarts`` random sequences: each sweep scores
every single-action flip of the current sequence and takes the best one while it improves
the score; the best local optimum over the restarts wins. The search runs compiled
(:mod:`wildfire_agent.planner_compiled`); :mod:`wildfire_agent.planner_reference` holds the
same search in numpy, which the compiled one equals float for float (tested, and
``wildfire bench --only rh`` times both).

Defaults: T = 60 (6 s ahead), tau = 10 (re-plan every second), 4 restarts. A 180 degree turn
at the bank limit takes 5.4 s, so shorter horizons cannot see that turning back towards the
fire pays (T = 30 scored ~8 % lower on seeds 100..105; T = 80, tau = 20 ~1 % higher at 25 %
more compute). A plan costs ~1.2 ms per aircraft on one core (the numpy search ~12 ms), i.e.
~0.16 ms per decision, far inside the 100 ms of a decision (``wildfire bench`` reports it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from wildfire_agent import planner_reference
from wildfire_agent.dynamics import AircraftState, constant_bank_track
from wildfire_agent.planner_reference import plan_model
from wildfire_agent.rewards import FireFieldMaps, ObservationRewardWeights


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
    believed_map: bool = False
    """Plan on the team's believed map, not the true fire (``rh-belief``)."""

    def __post_init__(self) -> None:
        if not 1 <= self.replan_every < self.horizon or self.restarts < 1:
            raise ValueError(
                "receding horizon: expected 1 <= replan_every < horizon and restarts >= 1, got "
                f"{self.replan_every}, {self.horizon}, {self.restarts}"
            )


class PlanProblem(NamedTuple):
    """The arguments of one :func:`plan` call."""

    own: AircraftState
    others: AircraftState
    env: np.ndarray
    maps: FireFieldMaps
    generators: list[np.random.Generator]
    config: RecedingHorizonConfig
    weights: ObservationRewardWeights


def plan(
    own: AircraftState,
    others: AircraftState,
    env: np.ndarray,
    maps: FireFieldMaps,
    generators: list[np.random.Generator],
    config: RecedingHorizonConfig,
    weights: ObservationRewardWeights,
    reference: bool = False,
) -> np.ndarray:
    """Best action sequence (P, T) for each of P aircraft ``own`` (fields (P,)).

    ``others`` has fields (P, K); ``env`` (P,) selects each aircraft's fire maps;
    ``generators[p]`` draws aircraft p's random restarts. ``reference`` runs the numpy
    search instead of the compiled one (the same plan, ~10x slower).
    """
    horizon, restarts, count = config.horizon, config.restarts, len(generators)
    if reference:
        track, search = constant_bank_track, planner_reference.search
    else:
        # Imported here: numba costs an agent node ~0.5 s of start-up, which only the
        # planner's nodes should pay.
        from wildfire_agent import planner_compiled

        track, search = planner_compiled.constant_bank_track, planner_compiled.search
    if config.model_others:
        # The others are predicted to hold their bank.
        others_xy = track(others, horizon)
    else:
        # Planning alone: no other aircraft in the model, so no proximity penalty.
        nobody = np.zeros((count, 0, horizon))
        others_xy = (nobody, nobody)
    # One row per (aircraft, restart).
    rows = np.repeat(np.arange(count), restarts)
    model = plan_model(own, env, maps, others_xy, weights).rows(rows)
    sequences = np.concatenate(
        [rng.integers(0, 2, size=(restarts, horizon)) for rng in generators]
    ).astype(np.int64)
    sequences, scores = search(model, sequences, config.max_sweeps)
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


class RecedingHorizonPolicy:
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
        self.on_plan: Callable[[PlanProblem], None] | None = None
        """Called with each plan's inputs before planning (``wildfire bench`` records them)."""

    def due(self) -> np.ndarray:
        """(P,) bool: the aircraft that plan at their next :meth:`act` (only they read the
        maps: a caller may skip computing maps nobody reads)."""
        if not self._planned:
            return np.ones(len(self.generators), bool)
        return self._flown >= self._segment

    def act(
        self, own: AircraftState, others: AircraftState, env: np.ndarray, maps: FireFieldMaps
    ) -> np.ndarray:
        """Actions (P,) of the aircraft ``own`` (fields (P,)); others' fields are (P, K)."""
        due = self.due()
        if due.any():
            index = np.flatnonzero(due)
            problem = PlanProblem(
                AircraftState(*(field[index] for field in own)),
                AircraftState(*(field[index] for field in others)),
                env[index],
                maps,
                [self.generators[i] for i in index.tolist()],
                self.config,
                self.weights,
            )
            if self.on_plan is not None:
                self.on_plan(problem)
            self._plans[index] = plan(*problem)
            if self._planned:
                self._segment[index] = self.config.replan_every
            self._flown[index] = 0
            self._planned = True
        action = self._plans[np.arange(len(self.generators)), self._flown]
        self._flown += 1
        return action


__all__ = [
    "PlanProblem",
    "RecedingHorizonConfig",
    "RecedingHorizonPolicy",
    "plan",
    "replan_phases",
]
