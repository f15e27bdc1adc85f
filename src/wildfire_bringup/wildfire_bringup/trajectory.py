"""The team's flight as one array, from the stamped states each aircraft reported."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wildfire_msgs_py.input_guard import TickInbox


def stacked_trajectory(states: Sequence[TickInbox[np.ndarray]], lockstep: bool) -> np.ndarray:
    """(T, N, 4) states in time order from each aircraft's states by stamp.

    Lockstep: the states of every tick all aircraft reported. Real time (stamps differ
    between aircraft): each aircraft's states in order, cut to the shortest history.
    """
    if lockstep:
        common = sorted(set.intersection(*(set(s.items) for s in states)))
        return np.array([[s.items[t] for s in states] for t in common])
    length = min(len(s) for s in states)
    if length == 0:
        return np.zeros((0, len(states), 4))
    per_aircraft = [[s.items[t] for t in sorted(s.items)][:length] for s in states]
    return np.stack([np.array(rows) for rows in per_aircraft], axis=1)


__all__ = ["stacked_trajectory"]
