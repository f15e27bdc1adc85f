"""Epsilon-greedy exploration with persistent random actions (epsilon-z-greedy).

At 10 Hz one random ±5° bank change is undone by the next one: i.i.d. random actions make
the bank wander around zero and the aircraft fly roughly straight, so plain epsilon-greedy
never tries a turn. Here an exploring aircraft holds its random action for a random number
of decisions, uniform in 1..``max_hold`` (Dabney, Ostrovski & Barreto, "Temporally-Extended
epsilon-Greedy Exploration", 2021), which is a real manoeuvre: up to 20 decisions swing the
bank by up to 100°. The probability of starting such a run is set so that the fraction of
random decisions is still epsilon; ``max_hold = 1`` is plain epsilon-greedy.
"""

from __future__ import annotations

import numpy as np


class PersistentExploration:
    """Chooses between greedy and held random actions for (num_envs, n_aircraft) aircraft."""

    def __init__(self, num_envs: int, n_aircraft: int, max_hold: int) -> None:
        self.max_hold = max_hold
        self.mean_hold = (max_hold + 1) / 2.0
        self.held_action = np.zeros((num_envs, n_aircraft), dtype=np.int64)
        self.hold_left = np.zeros((num_envs, n_aircraft), dtype=np.int64)

    def start_probability(self, epsilon: float) -> float:
        """Chance per greedy decision to start a random run, for a random fraction epsilon.

        A run of mean length z follows a geometric greedy stretch of mean (1 - p) / p, so the
        random fraction is p z / (p z + 1 - p) = epsilon: p = epsilon / (z (1 - epsilon) +
        epsilon).
        """
        z = self.mean_hold
        return epsilon / (z * (1.0 - epsilon) + epsilon)

    def actions(self, greedy: np.ndarray, epsilon: float, rng: np.random.Generator) -> np.ndarray:
        """Actions (num_envs, n_aircraft) given the greedy ones and the current epsilon."""
        holding = self.hold_left > 0
        start = ~holding & (rng.random(greedy.shape) < self.start_probability(epsilon))
        count = int(start.sum())
        self.held_action[start] = rng.integers(0, 2, count)
        self.hold_left[start] = rng.integers(1, self.max_hold + 1, count)
        exploring = self.hold_left > 0
        self.hold_left[exploring] -= 1
        return np.where(exploring, self.held_action, greedy)

    def reset(self, envs: np.ndarray) -> None:
        """New episodes in ``envs`` start greedy."""
        self.hold_left[envs] = 0


__all__ = ["PersistentExploration"]
