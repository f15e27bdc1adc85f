"""Policies that fly every aircraft of a :class:`WildfireVecEnv`.

Each wraps, for the whole batch, the policy that ``wildfire_agent.policy_names.make_policy``
builds from a policy name (the factory an agent's aircraft policy uses too): a
receding-horizon planner (``rh`` or ``rh-paper``), the random policy, or a TorchScript
Q-network; a vector policy of your own (``MODULE:ATTR``, ``wildfire_agent.user_policy``) flies
as it is, its actions checked. Per-aircraft
randomness comes from ``seeding.Stream.AIRCRAFT`` of the episode seed, so an aircraft flies
the same in a batch of 20 episodes, alone, or as its own agent node.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from torch import nn

from wildfire_agent import user_policy
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.pairwise import NEAREST_PEERS, nearest_others, other_indices
from wildfire_agent.policies import RandomPolicy, TorchScriptPolicy, greedy_actions_and_values
from wildfire_agent.policy_names import (
    ORACLE_POLICY,
    Policy,
    PolicyFactory,
    make_policy,
)
from wildfire_agent.receding_horizon import RecedingHorizonConfig, RecedingHorizonPolicy
from wildfire_agent.rewards import FireFieldMaps
from wildfire_learning.errors import LearningError
from wildfire_learning.oracle_policy import OracleVecPolicy
from wildfire_world.env import EnvConfig, VecPolicy, WildfireVecEnv


def flatten_aircraft(state: AircraftState) -> AircraftState:
    """(E, N) poses as (E * N,)."""
    return AircraftState(*(field.reshape(-1) for field in state))


def others_of(views: AircraftState) -> AircraftState:
    """For each of the E * N aircraft, the poses it knows of the other aircraft of its
    episode, (P, K), from the team views (E, N, N) of ``WildfireVecEnv.team_views``."""
    n = views.x_m.shape[-1]
    # Explicit sizes: alone (N = 1) each aircraft knows of no other, and -1 cannot be inferred.
    count = views.x_m.shape[0] * n
    if n - 1 <= NEAREST_PEERS:
        others = other_indices(n)
        receivers = np.arange(n)[:, None]
        return AircraftState(
            *(f[:, receivers, others].reshape(count, others.shape[1]) for f in views)
        )
    # A large fleet: each plans with the nearest peers it knows of (``pairwise``).
    own = np.arange(n)
    chosen = nearest_others(views)[:, own, own]  # (E, N, K)
    return AircraftState(
        *(np.take_along_axis(f, chosen, axis=-1).reshape(count, NEAREST_PEERS) for f in views)
    )


def map_index(env: WildfireVecEnv, believed_map: bool) -> np.ndarray:
    """(E * N,) each aircraft's index into the maps a planner plans on: its episode's map, or,
    planning on the believed map under limited radio links, its own replica's."""
    n = env.config.n_aircraft
    if believed_map and env.radio is not None:
        return np.arange(env.num_envs * n)
    return np.repeat(np.arange(env.num_envs), n)


def build_for(factory: PolicyFactory, env: WildfireVecEnv) -> Policy:
    """The factory's policy for every aircraft of every episode of ``env`` (after a reset)."""
    n = env.config.n_aircraft
    return factory.build(env.seeds, np.arange(n), n, env.config.obs_weights)


class RandomVecPolicy:
    """Uniformly random actions."""

    observation = "none"

    def __init__(self) -> None:
        self.policy: RandomPolicy | None = None

    def reset(self, env: WildfireVecEnv) -> None:
        policy = build_for(PolicyFactory(), env)
        assert isinstance(policy, RandomPolicy)
        self.policy = policy

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        assert self.policy is not None, "reset() first"
        return self.policy.act().reshape(env.num_envs, env.config.n_aircraft)


class RecedingHorizonVecPolicy:
    """A receding-horizon baseline (``rh``, ``rh-paper`` or ``rh-belief`` by its config),
    every aircraft planning on its own."""

    observation = "none"

    def __init__(self, config: RecedingHorizonConfig | None = None) -> None:
        self.config = config or RecedingHorizonConfig()
        self.planner: RecedingHorizonPolicy | None = None
        self._belief_maps: FireFieldMaps | None = None

    def reset(self, env: WildfireVecEnv) -> None:
        planner = build_for(PolicyFactory(planner=self.config), env)
        assert isinstance(planner, RecedingHorizonPolicy)
        self.planner = planner
        self._belief_maps = None

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        assert self.planner is not None, "reset() first"
        maps = env.maps
        if self.config.believed_map:
            # Only aircraft about to plan read the maps: the believed ones are made then.
            if self.planner.due().any() or self._belief_maps is None:
                self._belief_maps = env.believed_maps()
            maps = self._belief_maps
        actions = self.planner.act(
            flatten_aircraft(env.aircraft),
            others_of(env.team_views()),
            map_index(env, self.config.believed_map),
            maps,
        )
        return actions.reshape(env.num_envs, env.config.n_aircraft)


class QNetworkVecPolicy:
    """Greedy TorchScript Q-network (observation- or belief-based per its card).

    Each ownship is evaluated on its own (a batch of one image and its K pairwise states),
    exactly as an agent node evaluates it: a larger batch may let the math libraries pick
    other kernels, which can change the last bits of a Q-value and so, on a near tie, an
    action. Evaluation then flies bit-for-bit what the distributed system flies.
    """

    def __init__(
        self, path: str | Path | TorchScriptPolicy, device: str | torch.device = "cpu"
    ) -> None:
        if isinstance(path, TorchScriptPolicy):
            self.policy = path
        else:
            self.policy = TorchScriptPolicy(path, device=device)
        self.observation = self.policy.approach

    def reset(self, env: WildfireVecEnv) -> None:
        self.policy.check_sensor(env.config.sensor)

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        images, states = observations["image"], observations["state"]
        actions = np.zeros(images.shape[:2], dtype=np.int64)
        for e in np.flatnonzero(~env.done).tolist():
            for k in range(images.shape[1]):
                actions[e, k] = self.policy.act(images[e, k : k + 1], states[e, k : k + 1])[0]
        return actions


class GreedyVecPolicy:
    """The network being trained as an evaluation policy, all aircraft in one batch.

    (Deployment evaluates each ownship alone, see :class:`QNetworkVecPolicy`; a batch may
    pick other kernels and so differ in the last bits — fine for a learning curve.)
    ``greedy_q`` keeps, per decision, the (E, N) value the network gives the action it took.
    """

    def __init__(self, model: nn.Module, observation: str, channels_last: bool = False) -> None:
        self.model = model
        self.observation = observation
        self.channels_last = channels_last
        self.greedy_q: list[np.ndarray] = []

    def reset(self, env: WildfireVecEnv) -> None:
        self.greedy_q = []

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        images, states = observations["image"], observations["state"]
        e, n = images.shape[:2]
        actions, values = greedy_actions_and_values(
            self.model,
            images.reshape(e * n, *images.shape[2:]),
            states.reshape(e * n, *states.shape[2:]),
            self.channels_last,
        )
        self.greedy_q.append(values.reshape(e, n))
        return actions.reshape(e, n)


class UserVecPolicy:
    """A vector policy of your own (``MODULE:ATTR``), its actions checked each decision."""

    def __init__(self, name: str, policy: user_policy.VecPolicy) -> None:
        self.name = name
        self.policy = policy
        self.observation = str(policy.observation)

    def reset(self, env: WildfireVecEnv) -> None:
        self.policy.reset(env)

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        actions = self.policy.act(env, observations)
        return user_policy.checked_actions(
            actions, (env.num_envs, env.config.n_aircraft), self.name
        )


ORACLE_MAX_CELLS = 40_000
"""The largest map the clairvoyant bound flies (measured: see :func:`check_world`)."""


def check_world(policy: VecPolicy, config: EnvConfig) -> None:
    """Refuse (one line) a world ``policy`` cannot fly: its observation there, or a network
    trained on other images."""
    replace(config, observation=policy.observation).validate()
    if isinstance(policy, OracleVecPolicy) and config.geometry.cells > ORACLE_MAX_CELLS:
        raise LearningError(
            f"oracle: affordable up to {ORACLE_MAX_CELLS:,} cells (200 x 200), not "
            f"{config.geometry.text}: it plans on the whole known future of the map, and a "
            "60 s flight of 4 aircraft on 200 x 200 already plans for 48 s"
        )
    if isinstance(policy, QNetworkVecPolicy):
        policy.policy.check_sensor(config.sensor)


def make_vec_policy(
    policy: str,
    rh_config: RecedingHorizonConfig | None = None,
    device: str | torch.device = "cpu",
) -> VecPolicy:
    """VecPolicy for any policy name (``wildfire_agent.policy_names.make_policy``);
    ``rh_config`` sets T, tau and restarts of the planners, ``device`` where a Q-network runs.
    ``oracle``, the clairvoyant bound (``wildfire_learning.oracle``), is evaluation's own: the
    agent's factory does not know it."""
    if policy == ORACLE_POLICY:
        return OracleVecPolicy(incumbent=lambda name: make_vec_policy(name, rh_config, device))
    factory = make_policy(policy, rh_config, device)
    if factory.user is not None:
        return UserVecPolicy(policy, factory.user)
    if factory.network is not None:
        return QNetworkVecPolicy(factory.network)
    if factory.planner is not None:
        return RecedingHorizonVecPolicy(factory.planner)
    return RandomVecPolicy()


__all__ = [
    "ORACLE_MAX_CELLS",
    "GreedyVecPolicy",
    "QNetworkVecPolicy",
    "RandomVecPolicy",
    "RecedingHorizonVecPolicy",
    "UserVecPolicy",
    "build_for",
    "check_world",
    "make_vec_policy",
    "map_index",
]
