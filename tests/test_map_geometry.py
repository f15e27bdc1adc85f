"""The map's size as a world option: one geometry value, any R x C map, the paper's unchanged."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from wildfire_belief import visits
from wildfire_belief.visits import visit_windows, visited_cells
from wildfire_msgs_py.map_geometry import PAPER_MAP, MapGeometry, MapGeometryError
from wildfire_sim.fire import BatchedFire
from wildfire_sim.seeding import cell_uniforms
from wildfire_sim.shapes import seed_centre_m, shape_masks
from wildfire_world.env import EnvConfig, WildfireVecEnv

WILDFIRE = Path(sys.executable).with_name("wildfire")


def test_parse_and_the_user_range() -> None:
    assert MapGeometry.parse("500,300") == MapGeometry(500, 300)
    assert MapGeometry.parse("1000x1000").shape == (1000, 1000)
    assert MapGeometry.parse("100,100").is_paper
    for text in ("49,100", "100,2001", "a,b", "100"):
        with pytest.raises(MapGeometryError, match="map size"):
            MapGeometry.parse(text)
    geometry = MapGeometry(300, 500)
    assert (geometry.width_m, geometry.height_m, geometry.cells) == (5000.0, 3000.0, 150_000)


def test_shapes_sit_at_the_centre_of_any_map() -> None:
    geometry = MapGeometry(300, 500)
    masks = shape_masks("circular", geometry)
    assert masks.ignition.shape == (300, 500)
    assert masks.ignition.sum() == 25
    assert seed_centre_m(masks.ignition) == (2505.0, 1505.0)
    # The paper's map keeps its seed where it always was.
    assert seed_centre_m(shape_masks("circular", PAPER_MAP).ignition) == (505.0, 505.0)


def test_counter_draws_depend_on_seed_step_and_cell_only() -> None:
    cells = np.arange(10_000)
    drawn = cell_uniforms(np.full(cells.size, 7), np.full(cells.size, 3), cells)
    assert np.array_equal(drawn[::-1], cell_uniforms(7, 3, cells[::-1]))
    assert drawn.min() >= 0.0 and drawn.max() < 1.0
    assert abs(drawn.mean() - 0.5) < 0.02
    assert not np.array_equal(drawn, cell_uniforms(8, 3, cells))
    assert not np.array_equal(drawn, cell_uniforms(7, 4, cells))


def _field_fire(num_envs: int, seeds: list[int], full_window: bool) -> BatchedFire:
    geometry = MapGeometry(160, 220)
    masks = shape_masks("circular", geometry)
    fire = BatchedFire(num_envs, geometry=geometry)
    wind = np.array([0.5, -0.3])
    fire.reset(list(range(num_envs)), seeds, masks.ignition, masks.fuel, wind)
    for _ in range(40):
        if full_window:
            # Step the whole map instead of the burning region's box: another cut.
            fire._window = (0, geometry.rows, 0, geometry.cols)
        fire.step()
    return fire


def test_a_field_fire_depends_on_its_seed_only_not_on_the_cut_or_batch() -> None:
    batched = _field_fire(3, [11, 12, 13], full_window=False)
    whole = _field_fire(3, [11, 12, 13], full_window=True)
    alone = _field_fire(1, [12], full_window=False)
    assert np.array_equal(batched.burning, whole.burning)
    assert np.array_equal(batched.fuel, whole.fuel)
    assert np.array_equal(batched.burning[1], alone.burning[0])
    assert batched.burning[0].sum() > 25  # it spread


def test_visits_deduplicate_alike_by_scratch_array_and_by_sorting(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    geometry = MapGeometry(200, 300)
    rng = np.random.default_rng(5)
    x = rng.uniform(-50, geometry.width_m + 50, size=(3, 6))
    y = rng.uniform(-50, geometry.height_m + 50, size=(3, 6))
    x[:, 1], y[:, 1] = x[:, 0] + 30.0, y[:, 0]  # overlapping discs
    windows = visit_windows(x, y, geometry)
    env, cell = visited_cells(windows, geometry)
    monkeypatch.setattr(visits, "SCRATCH_CELLS", 0)
    env_sorted, cell_sorted = visited_cells(windows, geometry)
    assert sorted(zip(env.tolist(), cell.tolist(), strict=True)) == list(
        zip(env_sorted.tolist(), cell_sorted.tolist(), strict=True)
    )
    pairs = set(zip(env.tolist(), cell.tolist(), strict=True))
    assert (cell < geometry.cells).all() and cell.size == len(pairs)


def test_the_environment_flies_a_field_map_with_a_fleet() -> None:
    config = EnvConfig(
        n_aircraft=8, observation="belief", reward="belief", geometry=MapGeometry(300, 400)
    )
    env = WildfireVecEnv(config, 2)
    observations = env.reset([3, 4])
    assert env.fire.burning.shape == (2, 300, 400)
    assert observations["image"].shape[:2] == (2, 8)
    total = np.zeros(2, np.int64)
    for _ in range(60):
        result = env.step(np.random.default_rng(0).integers(0, 2, size=(2, 8)))
        total += result.team_reward
    assert (total > 0).all()
    assert np.array_equal(total, env.scores)


def _wildfire(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(WILDFIRE), *args], capture_output=True, text=True, timeout=120, check=False
    )


@pytest.mark.slow
def test_cli_map_size_flies_in_eval_and_bad_sizes_get_one_line(tmp_path: Path) -> None:
    done = _wildfire(
        "eval", "--policy", "rh", "--map-size", "200,300", "--aircraft", "4",
        "--episodes", "1", "--duration", "10", "--json",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert '"map_size": [\n    200,\n    300\n  ]' in done.stdout
    bad = _wildfire("eval", "--map-size", "49,100")
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and "--map-size" in bad.stderr, bad.stderr
    # The distributed system reads a user's raster as eval does: a bad one, one line.
    ignition = tmp_path / "ignition.npy"
    np.save(ignition, np.zeros((100, 100), dtype=np.uint8))
    refused = _wildfire("run", "--ignition-map", str(ignition), "--duration", "1")
    assert refused.returncode == 2
    assert refused.stderr.count("\n") == 1 and "no burning cell" in refused.stderr, refused.stderr


def test_ego_images_read_a_window_equal_to_the_whole_map() -> None:
    """On a field map an image warps only the cells around its aircraft: the very pixels
    that warping the whole map gives, near the edges and off the map too."""
    import cv2

    from wildfire_belief.ego_image import IMAGE_SIZE, ego_affine, ego_images

    rng = np.random.default_rng(4)
    burning = rng.random((2, 400, 500)) < 0.3
    age = rng.integers(0, 256, size=(2, 400, 500)).astype(np.float32)
    x = np.concatenate([rng.uniform(-800, 5800, size=(2, 6)), [[3.0], [4999.0]]], axis=1)
    y = np.concatenate([rng.uniform(-800, 4800, size=(2, 6)), [[3999.0], [2.0]]], axis=1)
    heading = rng.uniform(-np.pi, np.pi, size=x.shape)
    images = ego_images(burning, age, x, y, heading)
    for env in range(2):
        source = np.stack([burning[env].astype(np.float32), age[env] / 255.0], axis=-1)
        for k in range(x.shape[1]):
            whole = cv2.warpAffine(
                np.ascontiguousarray(source, dtype=np.float32),
                ego_affine(x[env, k], y[env, k], heading[env, k]),
                (IMAGE_SIZE, IMAGE_SIZE),
                flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=(0.0, 1.0, 0.0, 0.0),
            )
            np.testing.assert_array_equal(images[env, k], whole.transpose(2, 0, 1))


def test_parallel_api_at_field_scale() -> None:
    """PettingZoo's own API test passes on a 500 x 500 map with 16 aircraft; ``state()`` is a
    100 x 100 coarse map there, as ``state_space`` declares."""
    from pettingzoo.test import parallel_api_test

    from wildfire_world.parallel_env import WildfireParallelEnv

    config = EnvConfig(
        n_aircraft=16, observation="belief", reward="belief", geometry=MapGeometry(500, 500),
        max_duration_s=3.0,
    )  # fmt: skip
    env = WildfireParallelEnv(config)
    parallel_api_test(env, num_cycles=40)
    env.reset(seed=3)
    state = env.state()
    assert env.state_space.contains(state) and state.shape == (3, 100, 100)
    # The seed's 5 x 5 block burns in the centre 5-cell pixels: fractions, not 0/1.
    assert 0 < state[0].max() <= 1 and state[0].sum() * 25 == env._env.fire.burning[0].sum()
