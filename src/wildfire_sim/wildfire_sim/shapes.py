"""Ignition seeds ("shapes") and fuel masks of the scenarios in the paper.

Every shape is a pair of boolean ``(GRID_SIZE, GRID_SIZE)`` masks: the cells burning at
ignition and the cells that may hold fuel. Arbitrary masks are accepted by the fire model
as well; these are the named ones.

* ``circular``: a 5 x 5 block burning at the grid centre (rows and columns 48..52, so the
  seed's centre is the centre of cell (50, 50), at (505 m, 505 m)).
* ``t``: a T lying on its side: a north-south bar 3 cells wide (columns 49..51) from row 35
  to row 65, and a west arm 3 cells wide (rows 49..51) from column 35 to the bar; i.e. arms
  of 150 m reaching west, north and south from the centre cell.
* ``arc``: the circular seed with no fuel in the northern half (rows >= 52), so the seed
  rows 52 burn out at once and the front that grows is an open arc.
"""

from __future__ import annotations

from enum import StrEnum
from typing import NamedTuple

import numpy as np

from wildfire_sim.errors import FireConfigError
from wildfire_sim.grid import GRID_SIZE


class Shape(StrEnum):
    """Named ignition scenarios."""

    CIRCULAR = "circular"
    T = "t"
    ARC = "arc"

    @classmethod
    def parse(cls, name: str) -> Shape:
        """Shape from its name (case-insensitive), with a clear error for unknown names."""
        try:
            return cls(name.lower())
        except ValueError:
            choices = ", ".join(shape.value for shape in cls)
            raise FireConfigError(
                f"unknown fire shape {name!r}: expected one of {choices}"
            ) from None


class ShapeMasks(NamedTuple):
    """Boolean masks of one scenario."""

    ignition: np.ndarray
    """Cells burning at ignition, shape (GRID_SIZE, GRID_SIZE)."""
    fuel: np.ndarray
    """Cells that may hold fuel (others start with none), shape (GRID_SIZE, GRID_SIZE)."""


def shape_masks(shape: Shape | str, n: int = GRID_SIZE) -> ShapeMasks:
    """Ignition and fuel masks of a named shape on an ``n`` x ``n`` grid."""
    shape = Shape.parse(shape) if isinstance(shape, str) else shape
    centre = n // 2
    ignition = np.zeros((n, n), dtype=bool)
    fuel = np.ones((n, n), dtype=bool)
    if shape in (Shape.CIRCULAR, Shape.ARC):
        ignition[centre - 2 : centre + 3, centre - 2 : centre + 3] = True
    if shape is Shape.ARC:
        fuel[centre + 2 :, :] = False
    if shape is Shape.T:
        arm = 15
        ignition[centre - arm : centre + arm + 1, centre - 1 : centre + 2] = True
        ignition[centre - 1 : centre + 2, centre - arm : centre + 1] = True
    return ShapeMasks(ignition=ignition, fuel=fuel)


def seed_centre_m(ignition: np.ndarray, cell_size_m: float = 10.0) -> tuple[float, float]:
    """Centroid (x, y) in metres of the ignition cells: where aircraft start around."""
    rows, cols = np.nonzero(ignition)
    if rows.size == 0:
        raise FireConfigError("ignition mask has no burning cell")
    return float((cols.mean() + 0.5) * cell_size_m), float((rows.mean() + 0.5) * cell_size_m)


__all__ = ["Shape", "ShapeMasks", "seed_centre_m", "shape_masks"]
