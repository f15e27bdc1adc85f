"""A real-world-style land-cover GeoTIFF the repository makes itself (no download).

:func:`write_landcover` writes a CORINE-coded raster at 30 m cells in a UTM projection, as
the CORINE and LANDFIRE products come: a forest of mixed stands with grassland clearings
and shrub, a lake (water bodies, non-burnable), a village (urban fabric), and a road
(non-burnable) crossing north to south as a firebreak. The seed fixes the layout, so the
field scenario that flies it is reproducible. ``wildfire fire --fuel-map FILE --fuel-classes
corine`` reads it as any user raster is read.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

DEMO_CRS = "EPSG:32610"
"""UTM zone 10N (metres): a projected CRS, as the readers require."""
DEMO_CELL_M = 30.0
"""The raster's cell size (LANDFIRE's); it is resampled to the map's 10 m cells."""
DEMO_ORIGIN = (500_000.0, 4_200_000.0)
"""West and north edges of the raster in UTM metres."""


def landcover_codes(rows: int, cols: int, seed: int = 0) -> np.ndarray:
    """(rows, cols) uint16 CORINE codes, north-up (row 0 the northern edge)."""
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:rows, 0:cols].astype(np.float64)
    # Smooth noise picks the stand of each cell: the sum of a few random plane waves.
    noise = np.zeros((rows, cols))
    for _ in range(6):
        k = rng.uniform(0.02, 0.12, size=2) * rng.choice([-1, 1], size=2)
        noise += np.cos(k[0] * r + k[1] * c + rng.uniform(0, 2 * np.pi))
    codes = np.full((rows, cols), 313, dtype=np.uint16)  # mixed forest
    codes[noise > 0.9] = 312  # coniferous forest
    codes[noise < -0.9] = 311  # broad-leaved forest
    codes[noise > 2.0] = 324  # transitional woodland-shrub
    codes[noise < -2.2] = 321  # natural grassland
    lake_r, lake_c, radius = rows * 0.3, cols * 0.25, min(rows, cols) * 0.08
    codes[(r - lake_r) ** 2 + (c - lake_c) ** 2 < radius**2] = 512  # water bodies
    village = (np.abs(r - rows * 0.75) < rows * 0.04) & (np.abs(c - cols * 0.2) < cols * 0.05)
    codes[village] = 112  # discontinuous urban fabric
    # A road one raster cell (30 m) wide, meandering north to south east of the centre.
    road = np.round(cols * 0.62 + 4 * np.sin(np.arange(rows) / 9.0)).astype(int)
    codes[np.arange(rows), road] = 122  # road and rail networks
    return codes


def write_landcover(path: Path, rows: int = 200, cols: int = 200, seed: int = 0) -> Path:
    """Write :func:`landcover_codes` as a GeoTIFF (nodata 0) and return ``path``."""
    import rasterio
    from rasterio.transform import from_origin

    codes = landcover_codes(rows, cols, seed)
    transform = from_origin(*DEMO_ORIGIN, DEMO_CELL_M, DEMO_CELL_M)
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=rows,
        width=cols,
        count=1,
        dtype="uint16",
        crs=DEMO_CRS,
        transform=transform,
        nodata=0,
        compress="deflate",
    ) as raster:
        raster.write(codes, 1)
    return path


__all__ = ["DEMO_CELL_M", "DEMO_CRS", "landcover_codes", "write_landcover"]
