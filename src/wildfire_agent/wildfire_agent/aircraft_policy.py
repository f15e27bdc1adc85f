"""One aircraft's decision, as its agent node takes it (no ROS).

:class:`AircraftPolicy` flies aircraft ``k`` of a team of ``n`` with any policy name
(``policy_names.make_policy``, the factory the environment policies use too): a
receding-horizon planner (``rh`` or ``rh-paper``), uniformly random actions, a TorchScript
Q-network (``obs``, ``belief`` or a file) or a vector policy of your own (``MODULE:ATTR``,
``user_policy``). It calls the very functions
``wildfire_world.env`` and ``wildfire_learning.vec_policies`` call, with the same shapes
for the team arrays, so for the same inputs it picks the action the environment picks:

* randomness (random actions, planner restarts) comes from ``generator(seed, AIRCRAFT, k)``;
* the planner sees the whole team ``(1, n)``, ownship ``k`` and the others in
  ``pairwise.nearest_others`` order, on the true fire map of the tick;
* a Q-network gets a batch of one image (``approaches``) and the ``K`` normalised pairwise
  states of the ownship; with several other aircraft it sums the pairwise Q-values;
* a vector policy of your own gets a one-episode environment (``user_policy.OneAircraftEnv``,
  reset before its first decision, as evaluation resets it after the environment's reset)
  and observations whose row ``k`` is the ownship's, made as for a Q-network (the other
  rows are zeros: the policy is decentralised); its action ``[0, k]`` is flown.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wildfire_agent import camera_view, pairwise
from wildfire_agent.approaches import Approach, belief_images, sees_cameras, sensor_images
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.policies import RandomPolicy, TorchScriptPolicy
from wildfire_agent.policy_names import BUILTIN_POLICIES, make_policy
from wildfire_agent.receding_horizon import RecedingHorizonConfig, RecedingHorizonPolicy
from wildfire_agent.rewards import FireFieldMaps, ObservationRewardWeights, fire_field_maps
from wildfire_agent.user_policy import OneAircraftEnv, VecPolicy, checked_actions
from wildfire_msgs_py.belief_codec import believed_burning
from wildfire_msgs_py.codecs import VisitWindow

BUILTIN = BUILTIN_POLICIES


class AircraftPolicy:
    """Chooses the bank actions of one aircraft (see the module docstring)."""

    def __init__(
        self,
        policy: str,
        aircraft: int,
        n_aircraft: int,
        seed: int,
        rh_config: RecedingHorizonConfig | None = None,
        weights: ObservationRewardWeights | None = None,
        sensor: str = "disc",
    ) -> None:
        if not 0 <= aircraft < n_aircraft:
            raise AgentConfigError(f"aircraft {aircraft}: expected 0..{n_aircraft - 1}")
        self.aircraft = aircraft
        self.n_aircraft = n_aircraft
        self.seed = seed
        self.name = policy
        self.weights = weights or ObservationRewardWeights()
        factory = make_policy(policy, rh_config)
        self.observation = factory.observation
        self.user: VecPolicy | None = factory.user
        """A vector policy of your own (then :attr:`policy` is None)."""
        self.user_reset = False
        self.policy = (
            None if self.user else factory.build([seed], [aircraft], n_aircraft, self.weights)
        )
        if factory.network is not None:
            factory.network.check_sensor(sensor)
        self.camera_view = sees_cameras(self.observation, sensor)
        """The observation network sees its camera images (``camera_view``)."""
        if isinstance(self.policy, RecedingHorizonPolicy):
            # Load the compiled planner now, before the run (numba and its cached kernels,
            # ~0.6 s), not in the first real-time slot that plans.
            from wildfire_agent.planner_compiled import compile_kernels

            compile_kernels()
        self._maps: FireFieldMaps | None = None
        self._maps_key: object = None
        self._belief_maps: FireFieldMaps | None = None

    @property
    def needs_belief(self) -> bool:
        """True for a belief-based Q-network (it needs the shared belief and exact ages) and
        for ``rh-belief`` (it plans on the believed map)."""
        on_belief = isinstance(self.policy, RecedingHorizonPolicy) and (
            self.policy.config.believed_map
        )
        return self.observation == Approach.BELIEF or on_belief

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
        reports: Sequence[VisitWindow] | None = None,
    ) -> int:
        """Action (0: -5 deg, 1: +5 deg) of the ownship from the team poses, fields (n,).

        ``burning`` is the (H, W) truth of this tick (``fire_key`` identifies it, e.g. its
        stamp, so the planner's maps are computed once per fire step); ``belief`` (H, W),
        the team's probability of burning (bool under the disc and in radio replicas,
        float32 from ``/wildfire/belief``), and ``age_s`` (H, W) float32 are needed by
        belief-based networks and ``rh-belief`` only. ``reports``, the camera windows the
        ownship reported at this pose (None before its first report), make the observation
        network's images under camera sensing.
        """
        k = self.aircraft
        if isinstance(self.policy, RandomPolicy):
            return int(self.policy.act()[0])
        team_2d = AircraftState(*(np.asarray(field)[None] for field in team))  # (1, n)
        if self.policy is None:
            return self.user_action(team_2d, burning, belief, age_s, reports)
        if isinstance(self.policy, RecedingHorizonPolicy):
            others = pairwise.nearest_others(team_2d)[0, k]
            own = AircraftState(*(field[0, k : k + 1] for field in team_2d))
            peers = AircraftState(*(field[0, others][None] for field in team_2d))
            if not self.policy.config.believed_map:
                maps = self.fire_maps(burning, fire_key)
            elif belief is None:
                raise ValueError("rh-belief plans on the believed map: it needs the belief")
            else:
                # The belief changes every decision; only a plan reads the maps, so they are
                # made only when one is due.
                if self.policy.due().any() or self._belief_maps is None:
                    believed = believed_burning(belief)
                    self._belief_maps = fire_field_maps(believed[None], self.weights)
                maps = self._belief_maps
            return int(self.policy.act(own, peers, np.zeros(1, dtype=np.int64), maps)[0])
        network: TorchScriptPolicy = self.policy
        image, states = self.observe(team_2d, burning, belief, age_s, reports)
        assert image is not None
        return int(network.act(image, states)[0])

    def observe(
        self,
        team_2d: AircraftState,
        burning: np.ndarray,
        belief: np.ndarray | None,
        age_s: np.ndarray | None,
        reports: Sequence[VisitWindow] | None,
    ) -> tuple[np.ndarray | None, np.ndarray]:
        """The ownship's image (1, C, H, W), None for the observation ``none``, and its
        normalised pairwise states (1, K, 5): its row of the environment's observations."""
        k = self.aircraft
        states = pairwise.normalise(pairwise.pairwise_states(team_2d))[0, k : k + 1]
        if self.observation not in (Approach.OBS, Approach.BELIEF):
            return None, states
        if self.camera_view:
            return self.camera_image(team_2d, reports), states
        if self.observation == Approach.OBS:
            return sensor_images(burning[None], team_2d)[0, k : k + 1], states
        if belief is None or age_s is None:
            raise ValueError("a belief-based policy needs the belief and its ages")
        ownship = AircraftState(*(field[:, k : k + 1] for field in team_2d))
        return belief_images(belief[None], age_s[None], ownship)[0], states

    def user_action(
        self,
        team_2d: AircraftState,
        burning: np.ndarray,
        belief: np.ndarray | None,
        age_s: np.ndarray | None,
        reports: Sequence[VisitWindow] | None,
    ) -> int:
        """The ownship's action from a vector policy of your own (see the module docstring)."""
        assert self.user is not None
        k, n = self.aircraft, self.n_aircraft
        env = OneAircraftEnv.of(self.seed, team_2d)
        if not self.user_reset:
            self.user.reset(env)
            self.user_reset = True
        image, states = self.observe(team_2d, burning, belief, age_s, reports)
        observations = {"state": own_row(states, k, n)}
        if image is not None:
            observations["image"] = own_row(image, k, n)
        actions = checked_actions(self.user.act(env, observations), (1, n), self.name)
        return int(actions[0, k])

    def camera_image(
        self, team_2d: AircraftState, reports: Sequence[VisitWindow] | None
    ) -> np.ndarray:
        """The ownship's camera images (1, 4, 30, 20) from its reports, as the environment
        makes them (nothing reported yet: all ``NOTHING``)."""
        k = self.aircraft
        ownship = AircraftState(*(field[:, k : k + 1] for field in team_2d))
        if reports is None:
            return np.zeros((1, *camera_view.IMAGE_SHAPE), dtype=np.float32)
        codes, row0, col0 = camera_view.window_codes([reports])
        return camera_view.camera_images(codes[None], row0[None], col0[None], ownship)[0]


def own_row(values: np.ndarray, k: int, n: int) -> np.ndarray:
    """(1, n, ...) zeros with row ``k`` set to ``values`` (1, ...)."""
    rows = np.zeros((1, n, *values.shape[1:]), dtype=values.dtype)
    rows[0, k] = values[0]
    return rows


__all__ = ["BUILTIN", "AircraftPolicy", "own_row"]
