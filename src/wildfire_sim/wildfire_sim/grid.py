"""Geometry of the map shared by the fire, the aircraft sensors and the belief.

The geometry is one value, :class:`MapGeometry` (rows, columns of 10 m cells), defined by the
interface package because the messages share its layout; this module re-exports it for the
simulation code. Map frame: x east, y north, metres, origin at the south-west corner.
Arrays are indexed ``[row, col]`` with row 0 at the south, exactly as
``nav_msgs/OccupancyGrid`` stores them, so cell (r, c) has its centre at
((c + 0.5) * CELL_SIZE_M, (r + 0.5) * CELL_SIZE_M).
"""

from __future__ import annotations

from wildfire_msgs_py.map_geometry import (
    CELL_SIZE_M,
    MAX_SIDE,
    MIN_SIDE,
    PAPER_MAP,
    MapGeometry,
    MapGeometryError,
    geometry_of,
)

__all__ = [
    "CELL_SIZE_M",
    "MAX_SIDE",
    "MIN_SIDE",
    "PAPER_MAP",
    "MapGeometry",
    "MapGeometryError",
    "geometry_of",
]
