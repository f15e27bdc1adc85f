"""The map's geometry: one small value passed down to everything that needs the map's size.

Map frame: x east, y north, metres, origin at the south-west corner. Arrays are indexed
``[row, col]`` with row 0 at the south, exactly as ``nav_msgs/OccupancyGrid`` stores them,
so cell (r, c) has its centre at ((c + 0.5) * cell_size_m, (r + 0.5) * cell_size_m).

The paper's map (:data:`PAPER_MAP`) is 100 x 100 cells of 10 m; field maps are any R x C in
[:data:`MIN_SIDE`, :data:`MAX_SIDE`] (up to 20 km x 20 km). Cells are always 10 m: a raster
of another resolution is resampled to them when it is read, so every rule of the model that
counts cells (the fire's 5 x 5 stencil, the 100 m visit disc) keeps its meaning.

Code that needs the size asks the map it was given (``geometry.rows``), or the shape of the
array it was given; no module keeps a size of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wildfire_msgs_py.errors import WildfireRosError

CELL_SIZE_M = 10.0
"""Side of every cell in metres (an OccupancyGrid's ``resolution``)."""
MIN_SIDE = 50
"""Fewest cells along a side of a map."""
MAX_SIDE = 2000
"""Most cells along a side of a map (20 km at 10 m)."""


class MapGeometryError(WildfireRosError):
    """A map size outside what the model supports."""


@dataclass(frozen=True)
class MapGeometry:
    """Rows and columns of 10 m cells of one map (row 0 at the south)."""

    rows: int = 100
    """Cells from south to north."""
    cols: int = 100
    """Cells from west to east."""

    def __post_init__(self) -> None:
        # Any positive size is a map (tests use tiny ones); what a user may ask for is
        # checked where they ask (:meth:`parse`, :meth:`user_checked`).
        for name, value in (("rows", self.rows), ("cols", self.cols)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise MapGeometryError(f"map size: expected {name} >= 1, got {value!r}")

    @classmethod
    def parse(cls, text: str) -> MapGeometry:
        """The map of ``"R,C"`` (rows, columns), as ``--map-size`` takes it."""
        parts = text.lower().replace("x", ",").split(",")
        try:
            rows, cols = (int(part) for part in parts)
        except ValueError:
            raise MapGeometryError(
                f"map size: expected ROWS,COLS (whole numbers), got {text!r}"
            ) from None
        return cls(rows, cols).user_checked()

    def user_checked(self) -> MapGeometry:
        """Return self, or raise :class:`MapGeometryError` if a side is outside
        [:data:`MIN_SIDE`, :data:`MAX_SIDE`]."""
        for name, value in (("rows", self.rows), ("cols", self.cols)):
            if not MIN_SIDE <= value <= MAX_SIDE:
                raise MapGeometryError(
                    f"map size: expected {name} in [{MIN_SIDE}, {MAX_SIDE}], got {value}"
                )
        return self

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)``: the shape of every map-sized array."""
        return (self.rows, self.cols)

    @property
    def cells(self) -> int:
        """Cells of the map."""
        return self.rows * self.cols

    @property
    def cell_size_m(self) -> float:
        return CELL_SIZE_M

    @property
    def width_m(self) -> float:
        """West-east extent in metres."""
        return self.cols * CELL_SIZE_M

    @property
    def height_m(self) -> float:
        """South-north extent in metres."""
        return self.rows * CELL_SIZE_M

    @property
    def is_paper(self) -> bool:
        """The paper's 100 x 100 map, whose fire keeps its original random draws."""
        return self == PAPER_MAP

    @property
    def text(self) -> str:
        """``"R,C"``, as ``--map-size`` and the configs write it."""
        return f"{self.rows},{self.cols}"

    def cell_of(self, x_m: np.ndarray, y_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row and column (int64, possibly outside the map) of the cell holding (x, y)."""
        col = np.floor(np.asarray(x_m) / CELL_SIZE_M).astype(np.int64)
        row = np.floor(np.asarray(y_m) / CELL_SIZE_M).astype(np.int64)
        return row, col

    def inside(self, row: np.ndarray, col: np.ndarray) -> np.ndarray:
        """True where (row, col) is a cell of the map."""
        return (row >= 0) & (row < self.rows) & (col >= 0) & (col < self.cols)


PAPER_MAP = MapGeometry()
"""The paper's map: 100 x 100 cells of 10 m (1 km^2), the default of every command."""


def geometry_of(array: np.ndarray) -> MapGeometry:
    """The map whose cells are the last two axes of ``array``."""
    rows, cols = array.shape[-2:]
    return MapGeometry(int(rows), int(cols))


__all__ = [
    "CELL_SIZE_M",
    "MAX_SIDE",
    "MIN_SIDE",
    "PAPER_MAP",
    "MapGeometry",
    "MapGeometryError",
    "geometry_of",
]
