"""One wildfire episode as a PettingZoo ``ParallelEnv`` (agents ``uav0``, ``uav1``, ...).

A thin wrapper over :class:`~wildfire_world.env.WildfireVecEnv` with one environment:
see that module for the spaces, rewards, starting state and episode end. Each agent's
observation is a dict ``{"image": ..., "state": ...}``; ``state()`` is the global view:
true burning, believed burning and belief age / 255, at most :data:`STATE_SIDE` pixels a side
(on a field map each pixel is the mean of a block of cells: a coarse map; ``state_space``
says its shape).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from wildfire_agent.approaches import APPROACHES, image_shape
from wildfire_agent.pairwise import STATE_SIZE, peer_count
from wildfire_sim.grid import MapGeometry
from wildfire_world.env import EnvConfig, WildfireVecEnv

STATE_SIDE = 100
"""Most pixels along a side of ``state()``: the paper's map cell for cell, a field map in
blocks of ``ceil(side / 100)`` cells."""


def state_block(geometry: MapGeometry) -> int:
    """Cells per side of one ``state()`` pixel on ``geometry``."""
    return -(-max(geometry.rows, geometry.cols) // STATE_SIDE)


def coarse(grid: np.ndarray, block: int, outside: float) -> np.ndarray:
    """Block means of an (H, W) grid, float32; the last blocks padded with ``outside``."""
    grid = np.asarray(grid, dtype=np.float32)
    if block == 1:
        return grid
    rows, cols = (-(-side // block) * block for side in grid.shape)
    padded = np.full((rows, cols), outside, dtype=np.float32)
    padded[: grid.shape[0], : grid.shape[1]] = grid
    return padded.reshape(rows // block, block, cols // block, block).mean(axis=(1, 3))


class WildfireParallelEnv(ParallelEnv):  # type: ignore[misc]  # pettingzoo is untyped
    """PettingZoo parallel API over a single wildfire episode.

    Arguments: ``config`` (:class:`EnvConfig`; ``observation`` must be ``obs`` or
    ``belief``). ``reset(seed=...)`` fixes the whole episode; without a seed, one is drawn.
    """

    metadata: ClassVar[dict[str, Any]] = {"name": "wildfire_surveillance_v0", "render_modes": []}

    def __init__(self, config: EnvConfig | None = None) -> None:
        self.config = (config or EnvConfig()).validate()
        if self.config.observation not in APPROACHES:
            raise ValueError("WildfireParallelEnv needs observation 'obs' or 'belief'")
        self.possible_agents = [f"uav{k}" for k in range(self.config.n_aircraft)]
        self.agents: list[str] = []
        self._env = WildfireVecEnv(self.config, 1)
        shape = image_shape(self.config.observation, self.config.sensor)
        pairs = peer_count(self.config.n_aircraft)
        self._observation_space = spaces.Dict(
            {
                "image": spaces.Box(0.0, 1.0, shape, np.float32),
                "state": spaces.Box(-np.inf, np.inf, (pairs, STATE_SIZE), np.float32),
            }
        )
        self._action_space = spaces.Discrete(2)
        self._block = state_block(self.config.geometry)
        rows, cols = (-(-side // self._block) for side in self.config.geometry.shape)
        self.state_space = spaces.Box(0.0, 1.0, (3, rows, cols), np.float32)
        self._seed_rng = np.random.default_rng()

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Space[Any]:
        return self._action_space

    def _per_agent(self, observations: dict[str, np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
        return {
            agent: {"image": observations["image"][0, k], "state": observations["state"][0, k]}
            for k, agent in enumerate(self.possible_agents)
        }

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, Any]]]:
        if seed is None:
            seed = int(self._seed_rng.integers(0, 2**31))
        observations = self._env.reset([seed])
        self.agents = [] if self._env.done[0] else list(self.possible_agents)
        return self._per_agent(observations), {agent: {} for agent in self.possible_agents}

    def step(
        self, actions: dict[str, int]
    ) -> tuple[
        dict[str, dict[str, np.ndarray]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, int]],
    ]:
        joint = np.array([[int(actions[agent]) for agent in self.possible_agents]])
        result = self._env.step(joint)
        observations = self._per_agent(result.observations)
        rewards = {a: float(result.rewards[0, k]) for k, a in enumerate(self.possible_agents)}
        terminated = bool(result.terminated[0])
        truncated = bool(result.truncated[0])
        infos = {a: {"team_reward": int(result.team_reward[0])} for a in self.possible_agents}
        terminations = {agent: terminated for agent in self.agents}
        truncations = {agent: truncated for agent in self.agents}
        observations = {agent: observations[agent] for agent in self.agents}
        rewards = {agent: rewards[agent] for agent in self.agents}
        infos = {agent: infos[agent] for agent in self.agents}
        if terminated or truncated:
            self.agents = []
        return observations, rewards, terminations, truncations, infos

    def state(self) -> np.ndarray:
        """Global view, ``state_space``: true burning, believed burning, belief age / 255
        (outside the map: not burning, age 1)."""
        env, block = self._env, self._block
        age = env.belief.age_s()[0] / np.float32(255.0)
        return np.stack(
            [
                coarse(env.fire.burning[0], block, 0.0),
                coarse(env.belief.burning[0], block, 0.0),
                coarse(age, block, 1.0),
            ]
        ).astype(np.float32)

    @property
    def score(self) -> int:
        """Team score so far (docs/model.md, Evaluation)."""
        return int(self._env.scores[0])


__all__ = ["STATE_SIDE", "WildfireParallelEnv", "coarse", "state_block"]
