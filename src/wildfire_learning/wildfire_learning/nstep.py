"""n-step returns for the batched training loop.

At 10 Hz a single ±5° bank change barely moves the aircraft, and with one-step targets the
value of what happens 10 s later (gamma = 0.99) creeps back one decision per target-network
copy, i.e. per 1000 iterations. Summing the next ``n`` rewards in the target moves it back
``n`` decisions at a time. :class:`NStepAccumulator` holds the last ``n`` decisions of every
aircraft of every environment and releases a transition once it spans ``n`` decisions, or,
when its episode ends, every pending one (spanning fewer decisions, same next observation).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Transitions(NamedTuple):
    """Transitions ready for the replay (flat, one row per aircraft decision)."""

    obs_ids: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    """Discounted sums of ``steps`` rewards."""
    terminated: np.ndarray
    next_ids: np.ndarray
    steps: np.ndarray


class NStepAccumulator:
    """Pending decisions of ``num_envs`` x ``n_aircraft`` aircraft, turned into n-step transitions.

    All aircraft of an environment decide together, so the pending length is per environment.
    """

    def __init__(self, num_envs: int, n_aircraft: int, n_step: int, gamma: float) -> None:
        self.n_step = n_step
        self.gamma = gamma
        shape = (num_envs, n_step, n_aircraft)
        self.obs_ids = np.zeros(shape, dtype=np.int64)
        self.actions = np.zeros(shape, dtype=np.int64)
        self.rewards = np.zeros(shape, dtype=np.float64)
        self.length = np.zeros(num_envs, dtype=np.int64)
        self.discounts = gamma ** np.arange(n_step, dtype=np.float64)

    def push(
        self,
        envs: np.ndarray,
        obs_ids: np.ndarray,
        actions: np.ndarray,
        rewards: np.ndarray,
        next_ids: np.ndarray,
        terminated: np.ndarray,
        ended: np.ndarray,
    ) -> Transitions:
        """Add one decision of every aircraft of ``envs``; return the transitions now complete.

        ``obs_ids``, ``actions``, ``rewards``, ``next_ids``: (len(envs), n_aircraft);
        ``terminated``, ``ended`` (episode over, terminated or truncated): (len(envs),).
        """
        slot = self.length[envs]
        self.obs_ids[envs, slot] = obs_ids
        self.actions[envs, slot] = actions
        self.rewards[envs, slot] = rewards
        self.length[envs] += 1
        parts: list[Transitions] = []

        full = envs[(self.length[envs] == self.n_step) & ~ended]
        if full.size:
            # The oldest pending decision now spans n decisions: release it, shift the rest.
            returns = np.einsum("enk,n->ek", self.rewards[full], self.discounts)
            count = full.size * self.obs_ids.shape[2]
            next_full = next_ids[np.searchsorted(envs, full)]
            parts.append(
                Transitions(
                    self.obs_ids[full, 0].reshape(-1),
                    self.actions[full, 0].reshape(-1),
                    returns.reshape(-1),
                    np.zeros(count, dtype=np.float32),
                    next_full.reshape(-1),
                    np.full(count, self.n_step, dtype=np.uint8),
                )
            )
            for array in (self.obs_ids, self.actions, self.rewards):
                array[full, :-1] = array[full, 1:]
            self.length[full] -= 1

        for row in np.flatnonzero(ended):
            # Episode over: every pending decision bootstraps from the last observation.
            env, pending = envs[row], self.length[envs[row]]
            rewards = self.rewards[env, :pending]
            n_aircraft = rewards.shape[1]
            steps = pending - np.arange(pending)
            returns = np.stack(
                [self.discounts[: pending - i] @ rewards[i:] for i in range(pending)]
            )
            parts.append(
                Transitions(
                    self.obs_ids[env, :pending].reshape(-1),
                    self.actions[env, :pending].reshape(-1),
                    returns.reshape(-1),
                    np.full(pending * n_aircraft, float(terminated[row]), dtype=np.float32),
                    np.tile(next_ids[row], pending),
                    np.repeat(steps, n_aircraft).astype(np.uint8),
                )
            )
            self.length[env] = 0

        if not parts:
            empty = np.zeros(0, dtype=np.int64)
            return Transitions(
                empty,
                empty,
                np.zeros(0),
                np.zeros(0, dtype=np.float32),
                empty,
                np.zeros(0, dtype=np.uint8),
            )
        return Transitions(*(np.concatenate(column) for column in zip(*parts, strict=True)))

    def clear(self, envs: np.ndarray) -> None:
        """Drop the pending decisions of ``envs`` (their episodes were abandoned)."""
        self.length[envs] = 0


__all__ = ["NStepAccumulator", "Transitions"]
