"""A map that changes in places, on the wire: whole now and then, tiles in between.

The fuel map changes only where the fire burns, but it is the one grid that compresses
badly (every cell holds its own random amount): sent whole after every fire step, it was
nine tenths of a recorded bag at 1000 x 1000 (8.7 of 9.5 MB for a minute of flight). So the
fire simulator sends ``/wildfire/fuel_map`` whole at the start and every
:data:`WHOLE_EVERY_STEPS` fire steps (100 s), and after the other fire steps the
:data:`TILE` x :data:`TILE` tiles of the map in which a cell changed on
``/wildfire/fuel_tiles``: ordinary OccupancyGrids whose ``info.origin`` places them (any
ROS tool reads them; RViz and Foxglove draw them in place).

:func:`changed_tiles` cuts them (the sender); :class:`TiledMap` rebuilds the map from a
whole grid and the tiles after it, whatever their order of arrival: each tile's region keeps
the newest stamp it was written with (the receiver).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from wildfire_msgs_py.codecs import grid_to_msg
from wildfire_msgs_py.map_geometry import CELL_SIZE_M, MapGeometry

TILE = 32
"""Cells along a tile's side; tiles sit on a grid of this pitch from the map's south-west
corner (the last row and column of tiles may be smaller)."""
WHOLE_EVERY_STEPS = 40
"""Fire steps from one whole map to the next (100 s)."""
PENDING_KEPT = 4096
"""Tiles a receiver holds until its first whole map arrives."""


class Tile(NamedTuple):
    """The values of one tile of the map: rows ``row0..``, columns ``col0..``."""

    stamp: int
    row0: int
    col0: int
    values: np.ndarray


def changed_tiles(stamp: int, old: np.ndarray, new: np.ndarray) -> list[Tile]:
    """The tiles of ``new`` in which a cell differs from ``old`` (same shape), row by row."""
    rows, cols = np.asarray(new).shape
    changed = np.asarray(old) != np.asarray(new)
    # Pad to whole tiles, then ask each tile whether any of its cells changed.
    padded = np.zeros((-(-rows // TILE) * TILE, -(-cols // TILE) * TILE), dtype=bool)
    padded[:rows, :cols] = changed
    blocks = padded.reshape(padded.shape[0] // TILE, TILE, padded.shape[1] // TILE, TILE)
    tiles = []
    for tile_row, tile_col in zip(*np.nonzero(blocks.any(axis=(1, 3))), strict=True):
        row0, col0 = int(tile_row) * TILE, int(tile_col) * TILE
        values = np.array(new[row0 : row0 + TILE, col0 : col0 + TILE])
        tiles.append(Tile(stamp, row0, col0, values))
    return tiles


def tile_shape(geometry: MapGeometry, row0: int, col0: int) -> tuple[int, int]:
    """The shape of the tile at (``row0``, ``col0``) of ``geometry`` (cut at the map's edge)."""
    return min(TILE, geometry.rows - row0), min(TILE, geometry.cols - col0)


def tile_to_msg(tile: Tile, *, message_class: Any = None) -> Any:
    """A tile -> ``nav_msgs/OccupancyGrid`` whose origin is the tile's south-west corner."""
    origin = (tile.col0 * CELL_SIZE_M, tile.row0 * CELL_SIZE_M)
    return grid_to_msg(tile.values, tile.stamp, origin_xy=origin, message_class=message_class)


class TiledMap:
    """The receiver's map: the newest whole grid, each tile region overwritten by its newest
    tile (a whole grid newer than a tile overwrites it too)."""

    def __init__(self) -> None:
        self.grid: np.ndarray | None = None
        self.stamps: np.ndarray | None = None
        """(tile rows, tile cols) int64: the stamp each tile region holds."""
        self.pending: list[Tile] = []
        """Tiles that arrived before the first whole grid."""

    def on_whole(self, stamp: int, grid: np.ndarray) -> None:
        if self.grid is None:
            self.grid = np.array(grid)
            rows, cols = self.grid.shape
            self.stamps = np.full((-(-rows // TILE), -(-cols // TILE)), stamp, dtype=np.int64)
            tiles, self.pending = self.pending, []
            for tile in tiles:
                self.on_tile(tile)
            return
        assert self.stamps is not None
        newer = np.repeat(np.repeat(self.stamps <= stamp, TILE, 0), TILE, 1)
        newer = newer[: self.grid.shape[0], : self.grid.shape[1]]
        self.grid[newer] = np.asarray(grid)[newer]
        np.maximum(self.stamps, stamp, out=self.stamps)

    def on_tile(self, tile: Tile) -> None:
        if self.grid is None or self.stamps is None:
            self.pending = [*self.pending[-PENDING_KEPT + 1 :], tile]
            return
        index = (tile.row0 // TILE, tile.col0 // TILE)
        if tile.stamp >= self.stamps[index]:
            rows, cols = tile.values.shape
            self.grid[tile.row0 : tile.row0 + rows, tile.col0 : tile.col0 + cols] = tile.values
            self.stamps[index] = tile.stamp


__all__ = [
    "TILE",
    "WHOLE_EVERY_STEPS",
    "Tile",
    "TiledMap",
    "changed_tiles",
    "tile_shape",
    "tile_to_msg",
]
