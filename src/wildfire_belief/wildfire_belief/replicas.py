"""Belief replicas: every aircraft's own copy of the belief, merged from the visits it hears.

See docs/model.md, Radio links. Each cell of a replica is a last-writer-wins register: it
holds the burning value of the newest visit it heard, newest by the visit's **key**
``(tick, aircraft)`` packed in one integer (:func:`visit_key`). Merging keeps, per cell, the
value of the greatest key, so the merge is commutative, associative and idempotent: two
replicas that heard the same visits are equal bit for bit, in whatever order and however
often the visits arrived. (Two aircraft that see a cell at the same tick read the same
truth; the aircraft index only makes the order total.)

A replica's age of a cell is the time since the tick of its newest visit, as in
:class:`~wildfire_belief.belief.SharedBelief`, which stays the team's union belief (the
score). Arrays are (E, R, H, W): R replicas per environment, one per aircraft in the
environment, one in an agent node.
"""

from __future__ import annotations

import numpy as np

from wildfire_belief.belief import AGE_CAP_TICKS, age_seconds
from wildfire_sim.grid import PAPER_MAP, MapGeometry

KEY_SHIFT = 6
"""Bits of the aircraft index in a visit key: the tick is ``key >> KEY_SHIFT`` (a shift, not a
division: ages are read from every key of every replica at each decision)."""
KEY_AIRCRAFT = 1 << KEY_SHIFT
"""Aircraft slots of a visit key (teams have at most 64 aircraft)."""
UNVISITED_KEY = -AGE_CAP_TICKS * KEY_AIRCRAFT
"""Key of a cell no visit has set: its age is the cap, and any visit is newer."""


def visit_key(tick: np.ndarray | int, aircraft: np.ndarray | int) -> np.ndarray:
    """The merge key of aircraft ``aircraft``'s visit at ``tick`` (int64)."""
    return (np.asarray(tick, dtype=np.int64) << KEY_SHIFT) | np.asarray(aircraft, dtype=np.int64)


class BeliefReplicas:
    """``replicas`` belief replicas in each of ``num_envs`` environments.

    Arrays: ``burning`` (E, R, H, W) bool; ``key`` (E, R, H, W) int64, the key of the visit
    that set each cell; ``now`` (E,) int64, the current tick.
    """

    def __init__(self, num_envs: int, replicas: int, geometry: MapGeometry = PAPER_MAP) -> None:
        shape = (num_envs, replicas, *geometry.shape)
        self.burning = np.zeros(shape, dtype=bool)
        self.key = np.full(shape, UNVISITED_KEY, dtype=np.int64)
        self.now = np.zeros(num_envs, dtype=np.int64)

    @property
    def cells(self) -> int:
        return self.burning.shape[-1] * self.burning.shape[-2]

    def reset(self, env_ids: np.ndarray | list[int], believed_burning: np.ndarray) -> None:
        """Start over: every replica believes ``believed_burning`` (k, H, W), ages at the cap."""
        env_ids = np.atleast_1d(np.asarray(env_ids, dtype=np.int64))
        self.burning[env_ids] = np.asarray(believed_burning, bool)[:, None]
        self.key[env_ids] = UNVISITED_KEY
        self.now[env_ids] = 0

    def tick(self, env_ids: np.ndarray | None = None) -> None:
        """Advance the clock of every (or the given) environment by one decision."""
        if env_ids is None:
            self.now += 1
        else:
            self.now[env_ids] += 1

    def merge(
        self,
        env: np.ndarray,
        replica: np.ndarray,
        cell: np.ndarray,
        key: np.ndarray,
        burning: np.ndarray,
    ) -> None:
        """Merge visited cells into replicas: per cell, the greatest key's value wins.

        Every argument is a flat array over the visited cells: environment, replica, flat
        cell index ``row * cols + col``, visit key and the burning value seen.
        """
        flat = (np.asarray(env, np.int64) * self.key.shape[1] + replica) * self.cells + cell
        keys, values = self.key.reshape(-1), self.burning.reshape(-1)
        # The newest key per cell first (duplicates in one call included), then the values of
        # exactly those visits: an update equal to the stored key is the same visit again.
        np.maximum.at(keys, flat, np.asarray(key, np.int64))
        newest = keys[flat] == key
        values[flat[newest]] = np.asarray(burning, bool)[newest]

    def last_visit(self) -> np.ndarray:
        """Tick of each cell's newest visit, (E, R, H, W) int64."""
        return self.key >> KEY_SHIFT

    def age_ticks(self) -> np.ndarray:
        """Deciseconds since each cell's newest visit, capped, (E, R, H, W) int64."""
        return np.minimum(self.now[:, None, None, None] - self.last_visit(), AGE_CAP_TICKS)

    def age_s(self) -> np.ndarray:
        """Seconds since each cell's newest visit, capped at 255, (E, R, H, W) float32."""
        return age_seconds(self.now[:, None, None, None], self.last_visit())


__all__ = ["KEY_AIRCRAFT", "KEY_SHIFT", "UNVISITED_KEY", "BeliefReplicas", "visit_key"]
