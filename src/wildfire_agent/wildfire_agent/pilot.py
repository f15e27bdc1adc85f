"""One aircraft's decision, as its agent node takes it (no ROS).

:class:`Pilot` wraps one policy for aircraft ``k`` of a team of ``n`` (``policy_names``): a
receding-horizon planner (``rh`` or ``rh-paper``), uniformly random actions, or a TorchScript
Q-network (``obs`` or ``belief`` input). It calls the very functions
``wildfire_learning.env`` and ``wildfire_learning.controllers`` call, with the same shapes
for the team arrays, so for the same inputs it picks the action the environment picks:

* randomness (random actions, planner restarts) comes from ``generator(seed, AIRCRAFT, k)``;
* the planner sees the whole team ``(1, n)``, ownship ``k`` and the others in
  ``pairwise.other_indices`` order, on the true fire map of the tick;
* a Q-network gets a batch of one image and the ``K`` normalised pairwise states of the
  ownship; with several other aircraft it sums the pairwise Q-values (``TorchScriptPolicy``).
"""

from __future__ import annotations

import numpy as np

from wildfire_agent import pairwise, sensor
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.policies import RandomPolicy, TorchScriptPolicy
from wildfire_agent.policy_names import BUILTIN_POLICIES, is_policy_file, planner_config
from wildfire_agent.receding_horizon import (
    RecedingHorizonConfig,
    RecedingHorizonController,
    replan_phases,
)
from wildfire_agent.rewards import FireFieldMaps, ObservationRewardWeights, fire_field_maps
from wildfire_sim.seeding import Stream, generator

BUILTIN = BUILTIN_POLICIES


class Pilot:
    """Chooses the bank actions of one aircraft (see the module docstring)."""

    def __init__(
        self,
        policy: str,
        aircraft: int,
        n_aircraft: int,
        seed: int,
        rh_config: RecedingHorizonConfig | None = None,
        weights: ObservationRewardWeights | None = None,
    ) -> None:
        if not 0 <= aircraft < n_aircraft:
            raise AgentConfigError(f"aircraft {aircraft}: expected 0..{n_aircraft - 1}")
        self.aircraft = aircraft
        self.n_aircraft = n_aircraft
        self.weights = weights or ObservationRewardWeights()
        rng = generator(seed, Stream.AIRCRAFT, aircraft)
        self.planner: RecedingHorizonController | None = None
        self.random: RandomPolicy | None = None
        self.network: TorchScriptPolicy | None = None
        rh_config = planner_config(policy, rh_config)
        if rh_config is not None:
            phase = replan_phases(np.array([aircraft]), n_aircraft, rh_config.replan_every)
            self.planner = RecedingHorizonController([rng], rh_config, self.weights, phase)
            self.observation = "none"
        elif policy == "random":
            self.random = RandomPolicy([rng])
            self.observation = "none"
        elif is_policy_file(policy):
            self.network = TorchScriptPolicy(policy)
            self.observation = self.network.approach
        else:
            raise AgentConfigError(
                f"policy {policy!r}: expected rh, rh-paper, random or a TorchScript .pt file"
            )
        self._maps: FireFieldMaps | None = None
        self._maps_key: object = None

    @property
    def needs_belief(self) -> bool:
        """True for a belief-based Q-network (it needs the shared belief and exact ages)."""
        return self.observation == "belief"

    def fire_maps(self, burning: np.ndarray, key: object) -> FireFieldMaps:
        """Reward look-up maps of the (H, W) truth, computed once per fire map ``key``."""
        if self._maps is None or key != self._maps_key:
            self._maps = fire_field_maps(burning[None], self.weights)
            self._maps_key = key
        return self._maps

    def decide(
        self,
        team: AircraftState,
        burning: np.ndarray,
        fire_key: object = None,
        belief: np.ndarray | None = None,
        age_s: np.ndarray | None = None,
    ) -> int:
        """Action (0: -5 deg, 1: +5 deg) of the ownship from the team poses, fields (n,).

        ``burning`` is the (H, W) truth of this tick (``fire_key`` identifies it, e.g. its
        stamp, so the planner's maps are computed once per fire step); ``belief`` (H, W)
        bool and ``age_s`` (H, W) float32 are needed by belief-based networks only.
        """
        k = self.aircraft
        if self.random is not None:
            return int(self.random.act()[0])
        team_2d = AircraftState(*(np.asarray(field)[None] for field in team))  # (1, n)
        if self.planner is not None:
            others = pairwise.other_indices(self.n_aircraft)[k]
            own = AircraftState(*(field[0, k : k + 1] for field in team_2d))
            peers = AircraftState(*(field[0, others][None] for field in team_2d))
            maps = self.fire_maps(burning, fire_key)
            return int(self.planner.act(own, peers, np.zeros(1, dtype=np.int64), maps)[0])
        assert self.network is not None
        states = pairwise.normalise(pairwise.pairwise_states(team_2d))[0, k : k + 1]
        if self.observation == "obs":
            image = sensor.observe(burning[None], team_2d.x_m, team_2d.y_m, team_2d.heading_rad)[
                0, k : k + 1, None
            ].astype(np.float32)
        else:
            if belief is None or age_s is None:
                raise ValueError("a belief-based policy needs the belief and its ages")
            from wildfire_belief.ego_image import ego_images

            image = ego_images(
                belief[None],
                age_s[None],
                team_2d.x_m[:, k : k + 1],
                team_2d.y_m[:, k : k + 1],
                team_2d.heading_rad[:, k : k + 1],
            )[0]
        return int(self.network.act(image, states)[0])


__all__ = ["BUILTIN", "Pilot"]
