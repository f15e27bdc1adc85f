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
from typing import NamedTuple, Protocol

import numpy as np

from wildfire_belief.belief import TICKS_PER_S, SharedBelief
from wildfire_belief.visits import VisitWindows, visited_cells
from wildfire_sim.grid import geometry_of


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


class VisitMask(NamedTuple):
    """A visit window cut to some of its cells (a :class:`Window`)."""

    row0: int
    col0: int
    visited: np.ndarray
    burning: np.ndarray


class BeliefAggregator:
    """The shared belief of one episode and its cumulative team score."""

    def __init__(self, ignition_burning: np.ndarray) -> None:
        self.geometry = geometry_of(ignition_burning)
        self.belief = SharedBelief(1, self.geometry)
        self.belief.reset([0], ignition_burning)
        self.score = 0
        self.cell_stamp_ns = np.full(self.geometry.shape, -1, dtype=np.int64)
        """Stamp of the visit that last set each cell (real time, :meth:`fresher_visits`)."""

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
        truth_grid = np.zeros(self.geometry.shape, dtype=bool)
        for w in windows:
            i, j = np.nonzero(w.visited)
            truth_grid[w.row0 + i, w.col0 + j] = np.asarray(w.burning, bool)[i, j]
        env, cell = visited_cells(stacked, self.geometry)
        truth = truth_grid.reshape(-1)[cell]
        reward = int(self.belief.visit(env, cell, truth)[0])
        self.score += reward
        return reward

    def fresher_visits(self, stamped: Sequence[tuple[int, Window]]) -> list[VisitMask]:
        """Real time: the windows in stamp order, each cut to the cells it saw last.

        Visits of different aircraft arrive in any order (network delay, loss and retries),
        and an older look at a cell must not undo a newer one: applied late, it would turn a
        cell back to an outdated state and the next fresh visit would score it again. Each
        cell keeps the stamp of the visit that set it; a window keeps only the cells it saw
        no earlier than that. (Lockstep merges every aircraft's visit of one tick together,
        as the environment does, and never needs this.)
        """
        kept = []
        for stamp, window in sorted(stamped, key=lambda item: item[0]):
            rows, cols = np.nonzero(window.visited)
            rows, cols = rows + window.row0, cols + window.col0
            inside = self.geometry.inside(rows, cols)
            rows, cols = rows[inside], cols[inside]
            fresh = self.cell_stamp_ns[rows, cols] <= stamp
            self.cell_stamp_ns[rows[fresh], cols[fresh]] = stamp
            visited = np.zeros_like(np.asarray(window.visited, bool))
            visited[rows[fresh] - window.row0, cols[fresh] - window.col0] = True
            kept.append(VisitMask(window.row0, window.col0, visited, np.asarray(window.burning)))
        return kept

    def restore(self, time_s: float, score: float, believed: np.ndarray, age_s: np.ndarray) -> None:
        """Continue from a copy of the belief taken at ``time_s`` (ages exact to 0.1 s)."""
        now = round(time_s * TICKS_PER_S)
        self.belief.now[0] = now
        self.belief.burning[0] = np.asarray(believed, bool)
        self.belief.last_visit[0] = now - np.rint(np.asarray(age_s) * TICKS_PER_S).astype(np.int64)
        self.score = round(score)


__all__ = ["BeliefAggregator", "VisitMask"]
