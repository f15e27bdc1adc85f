"""Merging the aircraft's visit windows into the shared belief (no ROS).

:class:`BeliefAggregator` is what the belief-aggregator node runs, one decision at a time,
with the same calls as ``WildfireVecEnv._visit``: ``SharedBelief.tick()``, then every cell
visited by any aircraft (``visits.visited_cells``: a cell seen by two aircraft counts once)
takes its true value; the team reward is the number of visited cells believed not burning
that are burning. Windows arrive as ``(row0, col0, visited, burning)`` (the codecs'
``VisitWindow``), ``burning`` being the truth the aircraft read at its visited cells.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from wildfire_belief.belief import TICKS_PER_S, SharedBelief
from wildfire_belief.visits import VisitWindows, visited_cells
from wildfire_sim.grid import GRID_SIZE


class Window(Protocol):
    """A visit window (``wildfire_msgs_py.codecs.VisitWindow``, frozen: read-only fields)."""

    @property
    def row0(self) -> int: ...
    @property
    def col0(self) -> int: ...
    @property
    def visited(self) -> np.ndarray: ...
    @property
    def burning(self) -> np.ndarray: ...


class BeliefAggregator:
    """The shared belief of one episode and its cumulative team score."""

    def __init__(self, ignition_burning: np.ndarray) -> None:
        self.belief = SharedBelief(1)
        self.belief.reset([0], ignition_burning)
        self.score = 0

    @property
    def burning(self) -> np.ndarray:
        """(H, W) bool believed burning."""
        return self.belief.burning[0]

    @property
    def ticks(self) -> int:
        """Decisions merged so far."""
        return int(self.belief.now[0])

    def age_s(self) -> np.ndarray:
        """(H, W) float32 seconds since each cell was visited (capped at 255)."""
        return self.belief.age_s()[0]

    def merge(self, windows: Sequence[Window]) -> int:
        """One decision: tick the clock, apply the windows; return the team reward."""
        self.belief.tick()
        if not windows:
            return 0
        stacked = VisitWindows(
            row0=np.array([[w.row0 for w in windows]], dtype=np.int64),
            col0=np.array([[w.col0 for w in windows]], dtype=np.int64),
            visited=np.stack([np.asarray(w.visited, bool) for w in windows])[None],
        )
        truth_grid = np.zeros((GRID_SIZE, GRID_SIZE), dtype=bool)
        for w in windows:
            i, j = np.nonzero(w.visited)
            truth_grid[w.row0 + i, w.col0 + j] = np.asarray(w.burning, bool)[i, j]
        env, cell = visited_cells(stacked)
        truth = truth_grid.reshape(-1)[cell]
        reward = int(self.belief.visit(env, cell, truth)[0])
        self.score += reward
        return reward

    def restore(self, time_s: float, score: float, believed: np.ndarray, age_s: np.ndarray) -> None:
        """Continue from a copy of the belief taken at ``time_s`` (ages exact to 0.1 s)."""
        now = round(time_s * TICKS_PER_S)
        self.belief.now[0] = now
        self.belief.burning[0] = np.asarray(believed, bool)
        self.belief.last_visit[0] = now - np.rint(np.asarray(age_s) * TICKS_PER_S).astype(np.int64)
        self.score = round(score)


__all__ = ["BeliefAggregator"]
