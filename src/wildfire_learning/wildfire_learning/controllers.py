"""Controllers that fly every aircraft of a :class:`WildfireVecEnv`.

Each wraps one policy of ``wildfire_agent`` for the whole batch: a receding-horizon planner
(``rh`` or ``rh-paper``), the random controller, or a TorchScript Q-network; policy names
mean what ``wildfire_agent.policy_names`` says. Per-aircraft randomness comes
from ``seeding.Stream.AIRCRAFT`` of the episode seed, so an aircraft flies the same in a
batch of 20 episodes, alone, or as its own agent node.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np
import torch

from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.pairwise import other_indices
from wildfire_agent.policies import RandomPolicy, TorchScriptPolicy
from wildfire_agent.policy_names import (
    BUILTIN_POLICIES,
    EXPECTED_POLICIES,
    SHIPPED_POLICIES,
    is_policy_file,
    planner_config,
)
from wildfire_agent.receding_horizon import (
    RecedingHorizonConfig,
    RecedingHorizonController,
    replan_phases,
)
from wildfire_learning.env import WildfireVecEnv
from wildfire_sim.seeding import Stream, generator

MODELS_DIR = Path(__file__).resolve().parents[3] / "models"
"""Shipped policies (``obs_policy.pt``, ``belief_policy.pt``) in the repository."""


class Controller(Protocol):
    """Chooses the actions of every aircraft of every environment."""

    observation: str
    """What the environment must render for it: ``obs``, ``belief`` or ``none``."""

    def reset(self, env: WildfireVecEnv) -> None:
        """Called after ``env.reset``: (re)seed per-aircraft randomness and plans."""

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        """Actions (E, N) int64."""


def aircraft_generators(seeds: np.ndarray, n_aircraft: int) -> list[np.random.Generator]:
    """One generator per aircraft, environment-major: aircraft k of seed s -> (s, AIRCRAFT, k)."""
    return [generator(int(seed), Stream.AIRCRAFT, k) for seed in seeds for k in range(n_aircraft)]


def flatten_aircraft(state: AircraftState) -> AircraftState:
    """(E, N) poses as (E * N,)."""
    return AircraftState(*(field.reshape(-1) for field in state))


def others_of(state: AircraftState) -> AircraftState:
    """For each of the E * N aircraft, the poses of the other aircraft of its episode (P, K)."""
    others = other_indices(state.x_m.shape[1])
    return AircraftState(*(field[:, others].reshape(-1, others.shape[1]) for field in state))


class RandomController:
    """Uniformly random actions."""

    observation = "none"

    def __init__(self) -> None:
        self.policy: RandomPolicy | None = None

    def reset(self, env: WildfireVecEnv) -> None:
        self.policy = RandomPolicy(aircraft_generators(env.seeds, env.config.n_aircraft))

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        assert self.policy is not None, "reset() first"
        return self.policy.act().reshape(env.num_envs, env.config.n_aircraft)


class RecedingHorizonEnvController:
    """A receding-horizon baseline (``rh`` or ``rh-paper`` by ``config.model_others``), every
    aircraft planning on its own."""

    observation = "none"

    def __init__(self, config: RecedingHorizonConfig | None = None) -> None:
        self.config = config or RecedingHorizonConfig()
        self.planner: RecedingHorizonController | None = None

    def reset(self, env: WildfireVecEnv) -> None:
        n = env.config.n_aircraft
        self.planner = RecedingHorizonController(
            aircraft_generators(env.seeds, n),
            self.config,
            env.config.obs_weights,
            phases=np.tile(replan_phases(np.arange(n), n, self.config.replan_every), env.num_envs),
        )

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        assert self.planner is not None, "reset() first"
        n = env.config.n_aircraft
        env_index = np.repeat(np.arange(env.num_envs), n)
        actions = self.planner.act(
            flatten_aircraft(env.aircraft), others_of(env.aircraft), env_index, env.maps
        )
        return actions.reshape(env.num_envs, n)


class QNetworkController:
    """Greedy TorchScript Q-network (observation- or belief-based per its card).

    Each ownship is evaluated on its own (a batch of one image and its K pairwise states),
    exactly as an agent node evaluates it: a larger batch may let the math libraries pick
    other kernels, which can change the last bits of a Q-value and so, on a near tie, an
    action. Evaluation then flies bit-for-bit what the distributed system flies.
    """

    def __init__(self, path: str | Path, device: str | torch.device = "cpu") -> None:
        self.policy = TorchScriptPolicy(path, device=device)
        self.observation = self.policy.approach

    def reset(self, env: WildfireVecEnv) -> None:
        pass

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        images, states = observations["image"], observations["state"]
        actions = np.zeros(images.shape[:2], dtype=np.int64)
        for e in np.flatnonzero(~env.done).tolist():
            for k in range(images.shape[1]):
                actions[e, k] = self.policy.act(images[e, k : k + 1], states[e, k : k + 1])[0]
        return actions


def resolve_policy_path(name: str) -> Path:
    """Path of a policy given as ``obs``/``belief`` (shipped) or a file path."""
    if name in SHIPPED_POLICIES:
        path = MODELS_DIR / f"{name}_policy.pt"
        if not path.is_file():
            raise AgentConfigError(
                f"policy {name!r}: the shipped model {path} is missing "
                "(train one with `wildfire train`, or use rh, rh-paper, random or a .pt file)"
            )
        return path
    return Path(name)


def make_controller(
    policy: str,
    rh_config: RecedingHorizonConfig | None = None,
    device: str | torch.device = "cpu",
) -> Controller:
    """Controller for a policy name (``wildfire_agent.policy_names``); ``rh_config`` sets T,
    tau and restarts of the planners, ``device`` where a Q-network runs."""
    planner = planner_config(policy, rh_config)
    if planner is not None:
        return RecedingHorizonEnvController(planner)
    if policy == "random":
        return RandomController()
    if policy in SHIPPED_POLICIES or is_policy_file(policy):
        return QNetworkController(resolve_policy_path(policy), device)
    raise AgentConfigError(f"unknown policy {policy!r}: expected {EXPECTED_POLICIES}")


__all__ = [
    "BUILTIN_POLICIES",
    "MODELS_DIR",
    "SHIPPED_POLICIES",
    "Controller",
    "QNetworkController",
    "RandomController",
    "RecedingHorizonEnvController",
    "aircraft_generators",
    "make_controller",
    "resolve_policy_path",
]
