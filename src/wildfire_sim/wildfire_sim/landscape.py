"""The ground a fire burns on and how it starts: the map, its fuel, and the ignition.

A :class:`Landscape` is the world's part that no episode seed changes: the map's geometry,
an optional :class:`~wildfire_sim.fuel_map.FuelMap` (a raster's fuel ranges and spread
multipliers; without one every cell holds the paper's 15..20), and the starting fire when it
is not a named shape's:

* an ignition raster (``--ignition-map``): its cells burn at the start, every episode;
* ``--ignitions K``: K seeded 5 x 5 blocks, each centred on a random cell with fuel, at
  least :data:`IGNITION_MARGIN` of the map's shorter side (and ``border_cells + 3`` cells)
  from the edge, so that no fire ends the flight early by reaching it, drawn from the
  episode seed's IGNITION stream.

Otherwise the named shape (circular, t, arc) burns at the map's centre. :meth:`start` is the
one rule every fire of the project starts by (the environment, the fire-simulator node,
``wildfire fire``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from wildfire_msgs_py.map_geometry import PAPER_MAP, MapGeometry
from wildfire_sim.errors import FireConfigError
from wildfire_sim.fuel_map import FuelMap
from wildfire_sim.seeding import Stream, generator
from wildfire_sim.shapes import Shape, ShapeMasks, shape_masks

BLOCK_RADIUS = 2
"""A seeded ignition is the (2 r + 1)^2 block around its cell: 5 x 5, the circular seed."""
MAX_IGNITIONS = 64
"""Most seeded ignitions of one episode."""
IGNITION_MARGIN = 0.2
"""Seeded ignitions keep this fraction of the map's shorter side from its edge. A fire
reaching the edge ends the episode (``wildfire_sim.episode``); downwind a fire runs about a
cell per fire step, so on a 1000 x 1000 map a fire lit 200 cells in flies most of a 400 s
flight. Lit anywhere, one of five fires near the edge ended flights at 0-110 s (measured:
1000 x 1000, 5 ignitions, 3 seeds)."""


@dataclass(frozen=True, eq=False)
class Landscape:
    """Map, fuel and starting fire of a world (the defaults: the paper's)."""

    geometry: MapGeometry = PAPER_MAP
    fuel: FuelMap | None = None
    """Fuel ranges and spread multipliers per cell; None: the fire parameters' range."""
    ignition_map: np.ndarray | None = None
    """(R, C) bool cells burning at the start; None: seeded blocks or the shape."""
    ignitions: int = 0
    """Seeded 5 x 5 blocks lit at the start (0: none; the shape or the map instead)."""

    def __post_init__(self) -> None:
        if self.fuel is not None and self.fuel.geometry != self.geometry:
            raise FireConfigError(
                f"fuel map: {self.fuel.geometry.text} cells, the map {self.geometry.text}"
            )
        if self.ignition_map is not None and self.ignition_map.shape != self.geometry.shape:
            raise FireConfigError(f"ignition map: expected {self.geometry.text} cells")
        if not 0 <= self.ignitions <= MAX_IGNITIONS:
            raise FireConfigError(f"--ignitions: expected 0..{MAX_IGNITIONS}, got {self.ignitions}")
        if self.ignitions and self.ignition_map is not None:
            raise FireConfigError("--ignitions and --ignition-map: give one of them")

    @property
    def has_rasters(self) -> bool:
        """Whether it holds what parameters cannot say: a fuel or an ignition raster."""
        return self.fuel is not None or self.ignition_map is not None

    @property
    def is_paper(self) -> bool:
        """The paper's world: its map, its fuel, its named shapes."""
        return (
            self.geometry.is_paper
            and self.fuel is None
            and self.ignition_map is None
            and not self.ignitions
        )

    def start(self, shape: Shape | str, seed: int, border_cells: int) -> ShapeMasks:
        """Cells burning at ignition and cells that may hold fuel, for episode ``seed``."""
        masks = shape_masks(shape, self.geometry)
        fuel = masks.fuel if self.fuel is None else masks.fuel & self.fuel.burnable
        if self.ignition_map is not None:
            return ShapeMasks(ignition=self.ignition_map & fuel, fuel=fuel)
        if self.ignitions:
            return ShapeMasks(ignition=self.seeded_blocks(seed, fuel, border_cells), fuel=fuel)
        return ShapeMasks(ignition=masks.ignition, fuel=fuel)

    def seeded_blocks(self, seed: int, fuel: np.ndarray, border_cells: int) -> np.ndarray:
        """(R, C) bool: ``ignitions`` 5 x 5 blocks on distinct random cells with fuel."""
        margin = max(
            border_cells + BLOCK_RADIUS + 1, round(IGNITION_MARGIN * min(self.geometry.shape))
        )
        inner = np.zeros(self.geometry.shape, dtype=bool)
        inner[margin:-margin, margin:-margin] = True
        cells = np.flatnonzero(fuel & inner)
        if cells.size < self.ignitions:
            raise FireConfigError(
                f"--ignitions {self.ignitions}: only {cells.size} cells with fuel lie "
                f"{margin} cells or more from the map's edge"
            )
        rng = generator(seed, Stream.IGNITION)
        centres = rng.choice(cells, size=self.ignitions, replace=False)
        burning = np.zeros(self.geometry.shape, dtype=bool)
        for row, col in zip(*np.unravel_index(np.sort(centres), self.geometry.shape), strict=True):
            r = BLOCK_RADIUS
            burning[row - r : row + r + 1, col - r : col + r + 1] = True
        return burning & fuel

    @property
    def key(self) -> str:
        """A model card's key suffix: ``fuel<sha256 prefix>``, ``ign<K>``, ``ignmap<cells>``."""
        parts = []
        if self.fuel is not None:
            parts.append(f"fuel{self.fuel.sha256[:8]}")
        if self.ignitions:
            parts.append(f"ign{self.ignitions}")
        if self.ignition_map is not None:
            parts.append(f"ignmap{int(self.ignition_map.sum())}")
        return "_".join(parts) or "paper"

    def summary(self) -> dict[str, Any]:
        """What a JSON summary, a bag or a model card records of the world's ground."""
        out: dict[str, Any] = {"map_size": [self.geometry.rows, self.geometry.cols]}
        if self.fuel is not None:
            out["fuel_map"] = {"source": self.fuel.source, "sha256": self.fuel.sha256}
        if self.ignition_map is not None:
            out["ignition_cells"] = int(self.ignition_map.sum())
        if self.ignitions:
            out["ignitions"] = self.ignitions
        return out


PAPER_LANDSCAPE = Landscape()
"""The paper's world: 100 x 100 cells of homogeneous fuel, named shapes at the centre."""


@lru_cache(maxsize=8)
def read_landscape(
    geometry: MapGeometry | None,
    fuel_map: Path | None = None,
    fuel_classes: str | None = None,
    ignition_map: Path | None = None,
    ignitions: int = 0,
) -> Landscape | None:
    """The landscape the map options describe (``--map-size``, ``--fuel-map``,
    ``--fuel-classes``, ``--ignition-map``, ``--ignitions``); None for the paper's fuel and
    shapes on ``geometry``. A fuel map sets the map's extent unless ``geometry`` is given,
    and is then cut to it about its centre.

    The one reading of those options: the command line and a training run's config both
    call it. Cached, so that a config rebuilt many times reads its rasters once."""
    from wildfire_sim.fuel_map import FuelTable, read_fuel_map, read_ignition_map

    if fuel_classes and fuel_map is None:
        raise FireConfigError("--fuel-classes: expected a --fuel-map to read them from")
    fuel = None
    if fuel_map is not None:
        fuel = read_fuel_map(fuel_map, FuelTable.named(fuel_classes) if fuel_classes else None)
        if geometry is None:
            geometry = fuel.geometry
        elif geometry != fuel.geometry:
            fuel = fuel.cropped(geometry)
    geometry = geometry or PAPER_MAP
    if fuel is None and ignition_map is None and not ignitions:
        return None
    ignition = None if ignition_map is None else read_ignition_map(ignition_map, geometry)
    return Landscape(geometry, fuel, ignition, ignitions)


__all__ = [
    "BLOCK_RADIUS",
    "IGNITION_MARGIN",
    "MAX_IGNITIONS",
    "PAPER_LANDSCAPE",
    "Landscape",
    "read_landscape",
]
