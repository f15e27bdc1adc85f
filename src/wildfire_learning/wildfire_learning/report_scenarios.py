"""The scenarios a results report flies: the paper's, and field scenarios on large maps.

* ``SHAPE:N`` (``circular:2``): the paper's 1 km map, a named fire, N aircraft.
* ``field:RxC:ignitions=K:aircraft=N``: an R x C map of the paper's homogeneous fuel, K
  seeded fires (``wildfire_sim.landscape``) pre-burnt to :data:`PREBURN_M2_PER_FIRE` each.
* ``landcover:RxC:ignitions=K:aircraft=N``: the same on the CORINE land-cover raster the
  repository makes (``wildfire_sim.demo_raster``: forest, grassland, shrub, a lake, a
  village and a road as a firebreak), at 30 m cells resampled to the map's 10 m.

Every scenario flies the report's ``--duration`` (400 s by default, the paper's).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from wildfire_learning.errors import LearningError
from wildfire_msgs_py.map_geometry import MapGeometry, MapGeometryError
from wildfire_sim.fuel_map import FuelMap
from wildfire_sim.landscape import Landscape
from wildfire_sim.shapes import Shape
from wildfire_world.env import EnvConfig

FIELD_KINDS = ("field", "landcover")
"""Scenario kinds on a map of their own."""
PREBURN_M2_PER_FIRE = 100_000.0
"""A field scenario's fires start at 10 ha each (a 50 m seed is no field fire)."""
DEMO_CELL_FACTOR = 3
"""Map cells per raster cell of the generated land cover (30 m over 10 m)."""


@dataclass(frozen=True)
class Scenario:
    """A fire flown by a team of ``aircraft``: a named shape on the paper's map, or seeded
    fires on a field map (``kind`` ``field`` or ``landcover``)."""

    shape: str
    aircraft: int
    kind: str = "paper"
    map_size: tuple[int, int] = (100, 100)
    ignitions: int = 0

    @classmethod
    def parse(cls, text: str) -> Scenario:
        """``SHAPE:N`` or ``field|landcover:RxC:ignitions=K:aircraft=N``."""
        kind, sep, rest = text.partition(":")
        if kind in FIELD_KINDS:
            return cls._parse_field(text, kind, rest)
        if not sep or not rest.isdigit() or int(rest) < 1:
            raise LearningError(
                f"scenario {text!r}: expected SHAPE:N with N >= 1 aircraft, e.g. circular:2, "
                "or field:RxC:ignitions=K:aircraft=N"
            )
        return cls(Shape.parse(kind).value, int(rest))

    @classmethod
    def _parse_field(cls, text: str, kind: str, rest: str) -> Scenario:
        size, *options = rest.split(":")
        try:
            geometry = MapGeometry.parse(size)
            values = dict(option.split("=", 1) for option in options)
            ignitions, aircraft = int(values.pop("ignitions")), int(values.pop("aircraft"))
            if values or ignitions < 1 or aircraft < 1:
                raise ValueError
        except (MapGeometryError, KeyError, ValueError):
            raise LearningError(
                f"scenario {text!r}: expected {kind}:RxC:ignitions=K:aircraft=N with R, C in "
                "[50, 2000], K and N >= 1, e.g. field:500x500:ignitions=3:aircraft=8"
            ) from None
        if kind == "landcover" and (
            geometry.rows % DEMO_CELL_FACTOR or geometry.cols % DEMO_CELL_FACTOR
        ):
            raise LearningError(f"scenario {text!r}: the land cover's sides are multiples of 3")
        return cls(Shape.CIRCULAR.value, aircraft, kind, (geometry.rows, geometry.cols), ignitions)

    @property
    def is_field(self) -> bool:
        return self.kind in FIELD_KINDS

    @property
    def key(self) -> str:
        """``circular_2aircraft`` (the key model cards and the paper table use), or
        ``field500x500_ign3_8aircraft``."""
        if not self.is_field:
            return f"{self.shape}_{self.aircraft}aircraft"
        rows, cols = self.map_size
        return f"{self.kind}{rows}x{cols}_ign{self.ignitions}_{self.aircraft}aircraft"

    @property
    def title(self) -> str:
        if not self.is_field:
            return f"{'T' if self.shape == 't' else self.shape}, {self.aircraft} aircraft"
        rows, cols = self.map_size
        where = "land cover" if self.kind == "landcover" else "field"
        return f"{where} {rows} x {cols}, {self.ignitions} fires, {self.aircraft} aircraft"

    def config(self, base: EnvConfig, work_dir: Path) -> EnvConfig:
        """``base`` flown on this scenario (a land cover's raster written to ``work_dir``)."""
        config = replace(base, n_aircraft=self.aircraft, shapes=(self.shape,))
        if not self.is_field:
            return config
        geometry = MapGeometry(*self.map_size)
        fuel = None
        if self.kind == "landcover":
            fuel = demo_landcover(geometry, work_dir)
        return replace(
            config,
            geometry=geometry,
            landscape=Landscape(geometry, fuel, ignitions=self.ignitions),
            preburn_area_m2=PREBURN_M2_PER_FIRE * self.ignitions,
        )


def demo_landcover(geometry: MapGeometry, work_dir: Path) -> FuelMap:
    """The generated CORINE raster covering ``geometry``, read as any user raster is."""
    from wildfire_sim.demo_raster import write_landcover
    from wildfire_sim.fuel_map import FuelTable, read_fuel_map

    rows, cols = geometry.rows // DEMO_CELL_FACTOR, geometry.cols // DEMO_CELL_FACTOR
    path = work_dir / f"landcover_{rows}x{cols}_30m.tif"
    if not path.is_file():
        work_dir.mkdir(parents=True, exist_ok=True)
        write_landcover(path, rows, cols)
    return read_fuel_map(path, FuelTable.named("corine"))


__all__ = ["FIELD_KINDS", "PREBURN_M2_PER_FIRE", "Scenario", "demo_landcover"]
