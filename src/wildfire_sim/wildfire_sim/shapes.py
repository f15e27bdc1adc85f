"""Ignition seeds ("shapes") and fuel masks of the scenarios in the paper.

Every shape is a pair of boolean ``(rows, cols)`` masks of the map: the cells burning at
ignition and the cells that may hold fuel. Arbitrary masks are accepted by the fire model
as well; these are the named ones. A shape keeps its size in cells on every map and sits at
the map's centre cell (``rows // 2``, ``cols // 2``); on the paper's 100 x 100 map:

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
from wildfire_sim.grid import PAPER_MAP, MapGeometry


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
    """Cells burning at ignition, shape (rows, cols)."""
    fuel: np.ndarray
    """Cells that may hold fuel (others start with none), shape (rows, cols)."""


def shape_masks(shape: Shape | str, geometry: MapGeometry = PAPER_MAP) -> ShapeMasks:
    """Ignition and fuel masks of a named shape on the map ``geometry``."""
    shape = Shape.parse(shape) if isinstance(shape, str) else shape
    r, c = geometry.rows // 2, geometry.cols // 2
    ignition = np.zeros(geometry.shape, dtype=bool)
    fuel = np.ones(geometry.shape, dtype=bool)
    if shape in (Shape.CIRCULAR, Shape.ARC):
        ignition[r - 2 : r + 3, c - 2 : c + 3] = True
    if shape is Shape.ARC:
        fuel[r + 2 :, :] = False
    if shape is Shape.T:
        arm = 15
        ignition[r - arm : r + arm + 1, c - 1 : c + 2] = True
        ignition[r - 1 : r + 2, c - arm : c + 1] = True
    return ShapeMasks(ignition=ignition, fuel=fuel)


def seed_centre_m(ignition: np.ndarray, cell_size_m: float = 10.0) -> tuple[float, float]:
    """Centroid (x, y) in metres of the ignition cells: where aircraft start around."""
    rows, cols = np.nonzero(ignition)
    if rows.size == 0:
        raise FireConfigError("ignition mask has no burning cell")
    return float((cols.mean() + 0.5) * cell_size_m), float((rows.mean() + 0.5) * cell_size_m)


def start_centres_m(ignition: np.ndarray, n_aircraft: int, cell_size_m: float = 10.0) -> np.ndarray:
    """Where each aircraft starts around, (N, 2) metres: the fires spread the fleet.

    Each connected fire of the ignition (8-neighbours; numbered in scan order from the
    south-west) has its centroid; aircraft k starts around fire ``k mod K``. With one fire
    that is :func:`seed_centre_m` for every aircraft, exactly.
    """
    from scipy import ndimage

    labels, count = ndimage.label(ignition, structure=np.ones((3, 3), dtype=bool))
    if count <= 1:
        return np.tile(np.asarray(seed_centre_m(ignition, cell_size_m)), (n_aircraft, 1))
    rows_cols = np.asarray(ndimage.center_of_mass(ignition, labels, range(1, count + 1)))
    centres = (rows_cols[:, ::-1] + 0.5) * cell_size_m
    return centres[np.arange(n_aircraft) % count]


__all__ = ["Shape", "ShapeMasks", "seed_centre_m", "shape_masks", "start_centres_m"]
