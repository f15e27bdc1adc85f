"""Footprints as runs: per window row, the one stretch of columns a sensor sees.

A sensor's footprint in its square window (the 100 m disc, or a camera's view cut by its
300 m range and the map) is convex, so each window row holds at most one run of seen
cells: ``first <= column < stop``. Kept as runs, a batch's footprints cost per row, not
per cell, and their reports come out as flat lists directly (``run_cells``), in row-major
window order: the order of a mask's ``np.flatnonzero``, which fixes the order in which an
aircraft draws its report noise.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class WindowRuns(NamedTuple):
    """Seen columns ``first <= column < stop`` per window row, (..., rows) int64 each."""

    first: np.ndarray
    stop: np.ndarray

    def mask(self, side: int) -> np.ndarray:
        """The footprints as (..., rows, side) bool masks."""
        columns = np.arange(side)
        return (columns >= self.first[..., None]) & (columns < self.stop[..., None])

    def counts(self) -> np.ndarray:
        """Seen cells per row, (..., rows) int64."""
        return self.stop - self.first


def runs_of(mask: np.ndarray) -> WindowRuns:
    """The runs of a (..., rows, side) bool mask whose rows each hold one run (or none)."""
    mask = np.asarray(mask, dtype=bool)
    side = mask.shape[-1]
    count = mask.sum(axis=-1)
    first = np.where(count > 0, np.argmax(mask, axis=-1), 0)
    last_plus_one = side - np.argmax(mask[..., ::-1], axis=-1)
    if np.any((count > 0) & (last_plus_one - first != count)):
        raise ValueError("a footprint row holds more than one run of seen cells")
    return WindowRuns(first.astype(np.int64), (first + count).astype(np.int64))


def run_cells(runs: WindowRuns) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """Every seen cell of a batch of runs, in C order of the runs' dims, then by column.

    Returns the cells' run indices (a tuple, one array per dim of ``runs.first``: e.g.
    aircraft, camera, row) and their columns.
    """
    shape = runs.first.shape
    rows = shape[-1]
    first = np.ascontiguousarray(runs.first, dtype=np.int64).reshape(-1, rows)
    stop = np.ascontiguousarray(runs.stop, dtype=np.int64).reshape(-1, rows)
    # A compiled loop: the cells come out already split into footprint, row and column.
    # Imported here, not with this module: numba costs ~0.5 s of start-up, which only noisy
    # sensing needs (its users load it before a run: ``belief_kernels.compile_kernels``).
    from wildfire_belief import belief_kernels

    lead, row, column = belief_kernels.run_cells(first, stop, np.asarray(shape[:-1], np.int64))
    return (*lead, row), column


__all__ = ["WindowRuns", "run_cells", "runs_of"]
