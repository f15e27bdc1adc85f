"""Fuel of a field map read from a raster: a GeoTIFF (with rasterio) or a ``.npy``.

A :class:`FuelMap` holds, per 10 m cell of the map, the range the cell's initial fuel is
drawn from (in fire steps, as the paper's homogeneous 15..20) and a spread multiplier ``m``
of its ignition hazard (``p = 1 - (1 - p0) ** m``; 1 everywhere is the paper's fuel). A
raster gives it in one of two ways:

* **amounts** (the default): band 1 is the fuel in fire steps (>= 0, at most 127); the
  range is that one value and the multiplier 1;
* **classes** (``classes=`` a :class:`FuelTable`): band 1 holds land-cover or fuel-model
  codes, looked up in a YAML table (shipped: ``corine`` and ``fbfm13``, see
  ``fuel_tables/``).

Nodata and 0 mean nothing to burn (roads, rock, water, firebreaks).

A GeoTIFF must be north-up in a projected CRS in metres with square cells; its transform
gives the cell size, and it is resampled to 10 m cells (nearest for classes, the mean for
amounts). Its rows run north to south, the map's from south to north:
:func:`to_map_rows` is the one place that turns one into the other. A ``.npy`` has no
georeference: it is taken as already on 10 m cells, in the map's ``[row, col]`` layout.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from wildfire_msgs_py.map_geometry import CELL_SIZE_M, MAX_SIDE, MIN_SIDE, MapGeometry
from wildfire_sim.errors import FireConfigError

MAX_FUEL = 127
"""Most fire steps a cell can burn (fuel is stored as int8)."""
SCHEMES = ("corine", "fbfm13")
"""Class tables that ship with the package (``fuel_tables/<scheme>.yaml``)."""


@dataclass(frozen=True)
class FuelClass:
    """One row of a class table."""

    name: str
    fuel_min: int
    fuel_max: int
    spread: float


@dataclass(frozen=True)
class FuelTable:
    """Land-cover or fuel-model code -> fuel range and spread multiplier."""

    scheme: str
    classes: dict[int, FuelClass]

    @classmethod
    def named(cls, name: str) -> FuelTable:
        """A shipped table (``corine``, ``fbfm13``) or a YAML file of the same form."""
        if name.lower() in SCHEMES:
            text = resources.files("wildfire_sim").joinpath(f"fuel_tables/{name.lower()}.yaml")
            return cls.from_yaml(text.read_text(), name.lower())
        path = Path(name)
        if not path.is_file():
            raise FireConfigError(
                f"--fuel-classes {name}: expected one of {', '.join(SCHEMES)} or a YAML file"
            )
        return cls.from_yaml(path.read_text(), str(path))

    @classmethod
    def from_yaml(cls, text: str, source: str) -> FuelTable:
        """Parse ``scheme:`` and ``classes: {code: {name, fuel: [min, max], spread}}``."""
        import yaml

        try:
            document = yaml.safe_load(text)
            classes = {
                int(code): _fuel_class(row) for code, row in dict(document["classes"]).items()
            }
        except (yaml.YAMLError, KeyError, TypeError, ValueError) as error:
            raise FireConfigError(
                f"fuel class table {source}: expected classes: {{CODE: {{name, fuel: [MIN, "
                f"MAX], spread}}}} with 0 <= MIN <= MAX <= {MAX_FUEL}, spread >= 0 ({error})"
            ) from None
        return cls(scheme=str(document.get("scheme", source)), classes=classes)

    def lookup(self, codes: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, ...]:
        """(low, high, spread) arrays for ``codes`` where ``valid`` (elsewhere nothing)."""
        known = np.array(sorted(self.classes), dtype=np.int64)
        unknown = np.setdiff1d(np.unique(codes[valid]), known)
        if unknown.size:
            raise FireConfigError(
                f"fuel classes: codes {unknown[:5].tolist()} are not in the "
                f"{self.scheme} table (known: {known[:8].tolist()}...)"
            )
        rows = [self.classes[int(code)] for code in known]
        table = np.array([(c.fuel_min, c.fuel_max, c.spread) for c in rows], dtype=np.float64)
        index = np.searchsorted(known, np.where(valid, codes, known[0]))
        low, high, spread = (np.where(valid, table[index, k], 0.0) for k in range(3))
        return low.astype(np.int8), high.astype(np.int8), spread.astype(np.float32)


def _fuel_class(row: dict[str, Any]) -> FuelClass:
    low, high = (int(v) for v in row["fuel"])
    spread = float(row.get("spread", 1.0))
    if not (0 <= low <= high <= MAX_FUEL and spread >= 0 and np.isfinite(spread)):
        raise ValueError(f"bad row {row}")
    return FuelClass(str(row.get("name", "")), low, high, spread)


@dataclass(frozen=True, eq=False)
class FuelMap:
    """Per-cell fuel range and spread multiplier of one map, ``[row, col]``, row 0 south."""

    low: np.ndarray
    """(R, C) int8: fewest fire steps a cell burns (0 with ``high`` 0: nothing to burn)."""
    high: np.ndarray
    """(R, C) int8: most fire steps (inclusive)."""
    spread: np.ndarray | None
    """(R, C) float32 hazard multiplier, or None: 1 everywhere (no cost on a step)."""
    source: str
    """What it was read from (``path`` and, for classes, the table), for summaries."""
    sha256: str
    """SHA-256 of the file it was read from: bags and cards tell maps apart by it."""

    @property
    def geometry(self) -> MapGeometry:
        return MapGeometry(*self.low.shape)

    @property
    def burnable(self) -> np.ndarray:
        """(R, C) bool: cells that start with fuel."""
        return self.high > 0

    def cropped(self, geometry: MapGeometry) -> FuelMap:
        """The map's centre ``geometry`` (``--map-size`` smaller than the raster)."""
        window = centre_window(self.low.shape, geometry, "the fuel map")
        spread = None if self.spread is None else self.spread[window]
        return FuelMap(self.low[window], self.high[window], spread, self.source, self.sha256)


def centre_window(shape: tuple[int, ...], geometry: MapGeometry, what: str) -> tuple[slice, slice]:
    """The centre ``geometry`` of a raster of ``shape`` (a ``--map-size`` within it)."""
    rows, cols = shape
    if geometry.rows > rows or geometry.cols > cols:
        raise FireConfigError(
            f"--map-size {geometry.text}: {what} is only {rows},{cols} cells of 10 m"
        )
    r0, c0 = (rows - geometry.rows) // 2, (cols - geometry.cols) // 2
    return slice(r0, r0 + geometry.rows), slice(c0, c0 + geometry.cols)


def to_map_rows(raster: np.ndarray, north_up: bool = True) -> np.ndarray:
    """A raster's rows as the map's: row 0 at the south (a north-up raster is flipped)."""
    return np.ascontiguousarray(raster[::-1] if north_up else raster)


def read_band(path: Path, *, categorical: bool, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Band 1 of ``path`` on 10 m cells in map layout: (values, valid) arrays (R, C)."""
    if not path.is_file():
        raise FireConfigError(f"{what} {path}: no such file")
    if path.suffix == ".npy":
        try:
            values = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as error:
            raise FireConfigError(f"{what} {path}: not a readable .npy ({error})") from None
        if values.ndim != 2 or not (np.issubdtype(values.dtype, np.number) or values.dtype == bool):
            raise FireConfigError(
                f"{what} {path}: expected a 2-D numeric array, got {values.dtype} {values.shape}"
            )
        valid = np.isfinite(values) if np.issubdtype(values.dtype, np.floating) else None
        values = np.asarray(values)
        return _checked_size(values, path, what), (
            np.ones(values.shape, bool) if valid is None else valid
        )
    return _read_geotiff(path, categorical=categorical, what=what)


def _read_geotiff(path: Path, *, categorical: bool, what: str) -> tuple[np.ndarray, np.ndarray]:
    import rasterio
    from rasterio.enums import Resampling
    from rasterio.errors import RasterioError

    try:
        with rasterio.open(path) as raster:
            transform, crs = raster.transform, raster.crs
            if crs is None or not crs.is_projected or crs.linear_units not in ("metre", "meter"):
                raise FireConfigError(
                    f"{what} {path}: expected a projected CRS in metres, got "
                    f"{crs.to_string() if crs else 'none'}"
                )
            if transform.b != 0 or transform.d != 0:
                raise FireConfigError(f"{what} {path}: expected a north-up raster (no rotation)")
            cell_x, cell_y = abs(transform.a), abs(transform.e)
            if not np.isclose(cell_x, cell_y, rtol=1e-6):
                raise FireConfigError(
                    f"{what} {path}: expected square cells, got {cell_x:g} x {cell_y:g} m"
                )
            if categorical and raster.dtypes[0].startswith("float"):
                raise FireConfigError(
                    f"{what} {path}: expected integer class codes, got {raster.dtypes[0]}"
                )
            shape = (
                max(1, round(raster.height * cell_y / CELL_SIZE_M)),
                max(1, round(raster.width * cell_x / CELL_SIZE_M)),
            )
            band = raster.read(
                1,
                out_shape=shape,
                masked=True,
                resampling=Resampling.nearest if categorical else Resampling.average,
            )
    except RasterioError as error:
        raise FireConfigError(f"{what} {path}: not a readable GeoTIFF ({error})") from None
    north_up = transform.e < 0
    values = to_map_rows(np.ma.getdata(band), north_up)
    valid = to_map_rows(~np.ma.getmaskarray(band), north_up)
    return _checked_size(values, path, what), valid


def _checked_size(values: np.ndarray, path: Path, what: str) -> np.ndarray:
    rows, cols = values.shape
    if not (MIN_SIDE <= rows <= MAX_SIDE and MIN_SIDE <= cols <= MAX_SIDE):
        raise FireConfigError(
            f"{what} {path}: {rows} x {cols} cells of 10 m; expected each side in "
            f"[{MIN_SIDE}, {MAX_SIDE}]"
        )
    return values


def file_sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def read_fuel_map(path: Path, classes: FuelTable | None = None) -> FuelMap:
    """The :class:`FuelMap` of a GeoTIFF or ``.npy`` (amounts, or ``classes`` codes)."""
    what = "--fuel-map"
    values, valid = read_band(path, categorical=classes is not None, what=what)
    if classes is not None:
        if not np.issubdtype(values.dtype, np.integer):
            raise FireConfigError(
                f"{what} {path}: expected integer class codes, got {values.dtype}"
            )
        low, high, spread = classes.lookup(values.astype(np.int64), valid)
        return FuelMap(low, high, spread, f"{path} ({classes.scheme})", file_sha256(path))
    amounts = values.astype(np.float64)
    valid &= np.isfinite(amounts)
    if np.any(amounts[valid] < 0) or np.any(amounts[valid] > MAX_FUEL):
        raise FireConfigError(
            f"{what} {path}: expected fuel amounts in [0, {MAX_FUEL}] fire steps, got "
            f"[{amounts[valid].min():g}, {amounts[valid].max():g}]"
        )
    fuel = np.where(valid, np.rint(amounts), 0).astype(np.int8)
    return FuelMap(fuel, fuel.copy(), None, str(path), file_sha256(path))


def read_ignition_map(path: Path, geometry: MapGeometry) -> np.ndarray:
    """(R, C) bool cells burning at the start: band 1 nonzero (nodata: not burning)."""
    values, valid = read_band(path, categorical=True, what="--ignition-map")
    window = centre_window(values.shape, geometry, f"--ignition-map {path}")
    burning = (valid & (values != 0))[window]
    if not burning.any():
        raise FireConfigError(f"--ignition-map {path}: no burning cell")
    return burning


__all__ = [
    "MAX_FUEL",
    "SCHEMES",
    "FuelClass",
    "FuelMap",
    "FuelTable",
    "centre_window",
    "file_sha256",
    "read_band",
    "read_fuel_map",
    "read_ignition_map",
    "to_map_rows",
]
