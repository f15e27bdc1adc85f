"""Real fuel maps: GeoTIFF and .npy rasters, class tables, seeded ignitions, pre-burn to an area."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

rasterio = pytest.importorskip("rasterio")
from rasterio.transform import from_origin  # noqa: E402

from wildfire_msgs_py.map_geometry import MapGeometry  # noqa: E402
from wildfire_sim.demo_raster import landcover_codes, write_landcover  # noqa: E402
from wildfire_sim.episode import preburn  # noqa: E402
from wildfire_sim.fire import BatchedFire  # noqa: E402
from wildfire_sim.fuel_map import FuelMap, FuelTable, read_fuel_map  # noqa: E402
from wildfire_sim.landscape import Landscape  # noqa: E402
from wildfire_world.env import EnvConfig, WildfireVecEnv  # noqa: E402

WILDFIRE = [sys.executable, "-m", "wildfire_cli"]


def write_tif(path: Path, band: np.ndarray, cell_m: float, crs: str = "EPSG:32633", **kw) -> Path:
    """A north-up single-band GeoTIFF (row 0 the northern edge)."""
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=band.shape[0],
        width=band.shape[1],
        count=1,
        dtype=band.dtype,
        crs=crs,
        transform=from_origin(400_000.0, 5_000_000.0, cell_m, cell_m),
        **kw,
    ) as raster:
        raster.write(band, 1)
    return path


def wildfire(*args: str) -> subprocess.CompletedProcess[str]:
    code = "import sys; from wildfire_cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300
    )


def test_firebreak_and_nodata_lake_at_30_m(tmp_path: Path) -> None:
    """A 3-cell firebreak stops the fire, a nodata lake never burns, the map is the raster's
    extent at 10 m, and the saved arrays are in the map's layout (row 0 south)."""
    fuel = np.full((60, 70), 18.0, dtype=np.float32)
    fuel[:, 44:47] = 0.0  # a firebreak 3 raster cells (90 m) wide, east of the centre
    rows, cols = np.mgrid[0:60, 0:70]
    lake = (rows - 20) ** 2 + (cols - 20) ** 2 < 36  # north-west (row 0 is the north)
    fuel[lake] = -9999.0
    path = write_tif(tmp_path / "break.tif", fuel, 30.0, nodata=-9999.0)
    out = tmp_path / "fire.npz"
    done = wildfire("fire", "--fuel-map", str(path), "--steps", "400", "--seeds", "2",
                    "--out", str(out))  # fmt: skip
    assert done.returncode == 0, done.stderr
    saved = np.load(out)
    burning, left = saved["burning"], saved["fuel"]
    assert burning.shape == left.shape == (2, 180, 210)  # 60 x 70 cells of 30 m
    lake_map = np.kron(lake[::-1], np.ones((3, 3), dtype=bool))  # rows flipped: row 0 south
    west = np.zeros((180, 210), dtype=bool)
    west[:, :132] = True
    burnt_west = ((left < 18) & (west & ~lake_map)).sum(axis=(1, 2))
    assert burnt_west.min() > 5000
    assert (left[:, :, 141:] == 18).all() and not burning[:, :, 132:].any()
    assert (left[:, :, 132:141] == 0).all()
    # The lake: rows 20 +- 6 of 60 from the north -> map rows near (60 - 20) * 3 = 120.
    assert lake_map[115:125, 55:65].all()
    assert (left[:, lake_map] == 0).all() and not burning[:, lake_map].any()


def test_north_up_raster_is_flipped_and_npy_is_map_layout(tmp_path: Path) -> None:
    band = np.zeros((50, 60), dtype=np.int16)
    band[:10] = 7  # the northern ten rows
    fuel_map = read_fuel_map(write_tif(tmp_path / "north.tif", band, 10.0))
    assert fuel_map.geometry == MapGeometry(50, 60)
    assert (fuel_map.high[40:] == 7).all() and (fuel_map.high[:40] == 0).all()
    np.save(tmp_path / "map.npy", band)  # a .npy is the map's own layout: row 0 south
    assert (read_fuel_map(tmp_path / "map.npy").high[:10] == 7).all()


def test_amounts_are_averaged_when_the_raster_is_finer(tmp_path: Path) -> None:
    band = np.tile(np.array([[10, 20], [20, 30]], dtype=np.uint8), (60, 60))  # 5 m cells
    fuel_map = read_fuel_map(write_tif(tmp_path / "fine.tif", band, 5.0))
    assert fuel_map.geometry == MapGeometry(60, 60)
    assert (fuel_map.high == 20).all()


def test_corine_classes_and_the_demo_landcover(tmp_path: Path) -> None:
    path = write_landcover(tmp_path / "landcover.tif", rows=60, cols=60, seed=3)
    fuel_map = read_fuel_map(path, FuelTable.named("corine"))
    assert fuel_map.geometry == MapGeometry(180, 180)
    codes = np.kron(landcover_codes(60, 60, seed=3)[::-1], np.ones((3, 3), dtype=np.uint16))
    assert (fuel_map.high[codes == 512] == 0).all() and (fuel_map.high[codes == 122] == 0).all()
    forest = codes == 313
    assert (fuel_map.low[forest] == 15).all() and (fuel_map.high[forest] == 20).all()
    assert fuel_map.spread is not None and np.allclose(fuel_map.spread[codes == 321], 1.6)
    table = FuelTable.named("fbfm13")
    assert table.classes[1].spread > table.classes[8].spread  # grass runs, litter creeps
    assert table.classes[98].fuel_max == 0  # water


def test_spread_multiplier_speeds_the_fire() -> None:
    geometry = MapGeometry(120, 120)
    areas = []
    for spread in (1.0, 2.0):
        low = np.full(geometry.shape, 15, dtype=np.int8)
        fuel_map = FuelMap(low, low + 5, np.full(geometry.shape, spread, np.float32), "t", "")
        start = Landscape(geometry, fuel_map).start("circular", 0, 6)
        fire = BatchedFire(4, geometry=geometry, fuel_map=fuel_map)
        fire.reset(range(4), range(4), start.ignition, start.fuel, np.zeros(2))
        for _ in range(25):
            fire.step()
        areas.append(fire.affected().sum(axis=(1, 2)).mean())
    assert areas[1] > 1.5 * areas[0]


def test_seeded_ignitions_lie_on_fuel_away_from_the_border() -> None:
    geometry = MapGeometry(300, 300)
    low = np.full(geometry.shape, 15, dtype=np.int8)
    low[:, :150] = 0  # the western half holds nothing
    fuel_map = FuelMap(low, low + 5 * (low > 0), None, "t", "")
    landscape = Landscape(geometry, fuel_map, ignitions=5)
    first = landscape.start("circular", 11, border_cells=6).ignition
    assert (first == landscape.start("circular", 11, 6).ignition).all()  # the seed fixes it
    assert not (first == landscape.start("circular", 12, 6).ignition).all()
    rows, cols = np.nonzero(first)
    # A fifth of the side (60 cells) from the edge, less the block's radius of 2.
    assert cols.min() >= 150 and rows.min() >= 58 and rows.max() <= 241 and cols.max() <= 241
    assert 5 * 9 <= first.sum() <= 5 * 25  # five 5 x 5 blocks, some clipped at the halfline


def test_preburn_until_an_area() -> None:
    fire = BatchedFire(2, geometry=MapGeometry(200, 200))
    start = Landscape(MapGeometry(200, 200)).start("circular", 0, 6)
    fire.reset([0, 1], [0, 1], start.ignition, start.fuel, np.zeros(2))
    preburn(fire, np.array([True, False]), 0, area_m2=200_000.0)
    assert fire.affected()[0].sum() >= 2000 > fire.affected()[1].sum()
    assert fire.steps[1] == 0 < fire.steps[0]


def test_env_flies_a_fuel_map_with_ignitions(tmp_path: Path) -> None:
    path = write_landcover(tmp_path / "landcover.tif", rows=60, cols=60, seed=1)
    fuel_map = read_fuel_map(path, FuelTable.named("corine"))
    landscape = Landscape(fuel_map.geometry, fuel_map, ignitions=3)
    config = EnvConfig(
        n_aircraft=4, observation="belief", reward="belief", geometry=fuel_map.geometry,
        landscape=landscape, preburn_area_m2=40_000.0, max_duration_s=20.0,
    )  # fmt: skip
    env = WildfireVecEnv(config, 2)
    env.reset([5, 6])
    assert (env.fire.fuel[:, fuel_map.high == 0] == 0).all()
    assert (env.fire.affected().sum(axis=(1, 2)) >= 400).all()
    for _ in range(50):
        env.step(np.zeros((2, 4), dtype=np.int64))
    assert (env.scores > 0).all()


@pytest.mark.parametrize(
    ("band", "kw", "args", "expected"),
    [
        (np.ones((60, 60), np.uint8), {"crs": "EPSG:4326"}, [], "projected CRS in metres"),
        (np.ones((20, 20), np.uint8), {}, [], "expected each side in [50, 2000]"),
        (np.ones((60, 60), np.float32) * 311, {}, ["--fuel-classes", "corine"], "integer class"),
        (np.full((60, 60), 777, np.int16), {}, ["--fuel-classes", "corine"], "[777]"),
        (np.full((60, 60), 200, np.int16), {}, [], "fuel amounts in [0, 127]"),
    ],
)
def test_bad_rasters_get_one_line(
    tmp_path: Path, band: np.ndarray, kw: dict[str, str], args: list[str], expected: str
) -> None:
    path = write_tif(tmp_path / "bad.tif", band, 10.0, **kw)
    done = wildfire("fire", "--fuel-map", str(path), *args, "--steps", "1", "--seeds", "1")
    assert done.returncode == 2
    assert expected in done.stderr and len(done.stderr.strip().splitlines()) == 1


def test_unreadable_raster_gets_one_line(tmp_path: Path) -> None:
    path = tmp_path / "junk.tif"
    path.write_bytes(b"not a tiff")
    done = wildfire("fire", "--fuel-map", str(path), "--steps", "1")
    assert done.returncode == 2 and "not a readable GeoTIFF" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


def test_a_training_run_takes_the_map_options(tmp_path: Path) -> None:
    from wildfire_cli import build_parser
    from wildfire_cli.train import build_config

    path = write_landcover(tmp_path / "landcover.tif", rows=60, cols=80, seed=2)
    args = build_parser("train").parse_args(
        ["train", "--fuel-map", str(path), "--fuel-classes", "corine", "--ignitions", "2"]
    )
    config = build_config(args, None).validate()
    env_config = config.env_config()
    # The raster's extent at 10 m (30 m cells), read once by its absolute path.
    assert env_config.geometry == MapGeometry(180, 240)
    assert config.fuel_map == str(path.resolve())
    assert env_config.landscape is not None and env_config.landscape.ignitions == 2
    assert (
        env_config.ground.summary()["fuel_map"]["sha256"]
        == read_fuel_map(path, FuelTable.named("corine")).sha256
    )
    cut = build_config(build_parser("train").parse_args(["train", "--map-size", "200,150"]), None)
    assert cut.env_config().geometry == MapGeometry(200, 150) and cut.env_config().landscape is None
    result = wildfire("train", "--map-size", "40,100")
    assert result.returncode == 2 and "--map-size" in result.stderr
    assert "in [50, 2000]" in result.stderr and "Traceback" not in result.stderr


def test_map_size_sets_the_field_world_of_the_fire_and_env_suites() -> None:
    from wildfire_bench.core import bench_env, bench_fire
    from wildfire_sim.grid import MapGeometry

    fire = bench_fire(steps=2, batch_sizes=(4,), field_map=MapGeometry(200, 300))
    assert fire["field_map"] == "200,300" and fire["step_ms_map_field"] > 0
    assert fire["step_ms_map_ratio"] == fire["step_ms_map_field"] / fire["step_ms_map_100"]
    env = bench_env(decisions=3, batch_sizes=(8,), field_map=MapGeometry(200, 300))
    assert env["field_map"] == "200,300" and env["decisions_per_s_field"] > 0
    # A 200 x 300 field holds less than the default 1000 x 1000 one, more than the paper's.
    assert env["bytes_per_env_disc"] < env["bytes_per_env_field"] < 2e6
    result = wildfire("bench", "--only", "fire", "--map-size", "3000,100")
    assert result.returncode == 2 and "--map-size" in result.stderr
    assert "Traceback" not in result.stderr
