"""Fire model: physics rules, wind, reproducibility across batch sizes."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_sim.errors import FireConfigError
from wildfire_sim.fire import (
    LOG_SCALE,
    BatchedFire,
    FireParams,
    quantised_log_kernel,
    spread_kernel,
)
from wildfire_sim.shapes import Shape, seed_centre_m, shape_masks


def make_fire(seeds, shape="circular", wind=(0.0, 0.0)) -> BatchedFire:
    masks = shape_masks(shape)
    fire = BatchedFire(len(seeds))
    fire.reset(np.arange(len(seeds)), seeds, masks.ignition, masks.fuel, np.asarray(wind))
    return fire


def test_initial_fuel_in_range_and_seed_burns():
    fire = make_fire([0, 1])
    fuel = fire.fuel[fire.fuel > 0]
    assert fuel.min() >= 15 and fuel.max() <= 20
    assert set(np.unique(fuel)) == set(range(15, 21))
    assert fire.burning.sum(axis=(1, 2)).tolist() == [25, 25]


def test_fuel_less_cells_never_ignite():
    masks = shape_masks("circular")
    fuel_mask = masks.fuel.copy()
    fuel_mask[:, 53:56] = False  # a fire break east of the seed
    fire = BatchedFire(4)
    fire.reset(np.arange(4), np.arange(4), masks.ignition, fuel_mask, np.array([0.8, 0.0]))
    for _ in range(60):
        fire.step()
        assert not fire.affected()[:, :, 53:56].any()
        assert not (fire.burning & (fire.fuel == 0)).any()


def test_burning_cells_consume_fuel_and_go_out():
    fire = make_fire([3])
    before = fire.fuel.copy()
    burning_before = fire.burning.copy()
    fire.step()
    np.testing.assert_array_equal(fire.fuel[burning_before], before[burning_before] - 1)
    np.testing.assert_array_equal(fire.fuel[~burning_before], before[~burning_before])
    for _ in range(21):
        fire.step()
    # Seed cells held at most 20 fuel: after 22 steps all of them are out of fuel.
    ignition = shape_masks("circular").ignition
    assert not fire.burning[0][ignition].any()
    assert (fire.fuel[0][ignition] == 0).all()


def test_arc_fire_never_crosses_into_the_fuel_less_north():
    fire = make_fire(list(range(4)), shape="arc")
    for _ in range(50):
        fire.step()
    assert not fire.affected()[:, 52:, :].any()
    assert fire.affected()[:, :52, :].sum() > 4 * 300


def test_wind_drifts_the_fire_downwind():
    seeds = list(range(8))
    calm, east = make_fire(seeds), make_fire(seeds, wind=(0.8, 0.0))
    north = make_fire(seeds, wind=(0.0, 0.8))
    for _ in range(40):
        for fire in (calm, east, north):
            fire.step()

    def centroid(fire):
        _env, rows, cols = np.nonzero(fire.affected())
        return cols.mean(), rows.mean()

    calm_c, calm_r = centroid(calm)
    east_c, east_r = centroid(east)
    north_c, north_r = centroid(north)
    assert east_c > calm_c + 5 and abs(east_r - calm_r) < 2
    assert north_r > calm_r + 5 and abs(north_c - calm_c) < 2


def test_spread_kernel_orientation_and_distance():
    kernel = spread_kernel(np.array([0.5, 0.0]))
    # Source west of the target (column offset -1) is upwind of an east wind: more likely.
    assert kernel[2, 1] == pytest.approx(1.5 / 22)
    assert kernel[2, 3] == pytest.approx(0.5 / 22)
    assert kernel[0, 2] == pytest.approx(1.0 / (22 * 4))
    assert kernel[2, 2] == 0.0


def test_batched_equals_unbatched_for_the_same_seeds():
    seeds = [11, 5, 42, 7]
    winds = np.array([[0.3, -0.5], [0.0, 0.0], [-0.8, 0.8], [0.6, 0.1]])
    masks = shape_masks("t")
    batch = BatchedFire(4)
    batch.reset(np.arange(4), seeds, masks.ignition, masks.fuel, winds)
    singles = []
    for seed, wind in zip(seeds, winds, strict=True):
        single = BatchedFire(1)
        single.reset([0], [seed], masks.ignition, masks.fuel, wind)
        singles.append(single)
    for step in range(45):
        # Step only some environments now and then: out-of-phase stepping must not matter.
        mask = np.array([True, step % 3 != 0, True, True])
        batch.step(mask)
        for k, single in enumerate(singles):
            if mask[k]:
                single.step()
    for k, single in enumerate(singles):
        np.testing.assert_array_equal(batch.burning[k], single.burning[0])
        np.testing.assert_array_equal(batch.fuel[k], single.fuel[0])


def test_ignition_pressure_equals_exact_stencil():
    rng = np.random.default_rng(0)
    fire = make_fire([1, 2, 3], wind=(0.4, -0.7))
    fire._burning[:] = rng.random(fire._burning.shape) < 0.2
    pressure = fire.ignition_pressure().transpose(2, 0, 1)
    kernel = quantised_log_kernel(np.array([0.4, -0.7])).astype(np.int64)
    for env in range(3):
        padded = np.pad(fire.burning[env].astype(np.int64), 2)
        expected = np.zeros((100, 100), dtype=np.int64)
        for i in range(5):
            for j in range(5):
                expected += kernel[i, j] * padded[i : i + 100, j : j + 100]
        np.testing.assert_array_equal(pressure[env], expected)
    assert pressure.max() < 2**24 and LOG_SCALE == 2**16


def test_bad_parameters_are_named():
    with pytest.raises(FireConfigError, match="wind"):
        spread_kernel(np.array([1.5, 0.0]))
    with pytest.raises(FireConfigError, match="fuel_min"):
        FireParams(fuel_min=30, fuel_max=20).validate()
    with pytest.raises(FireConfigError, match="unknown fire shape"):
        Shape.parse("square")


def test_shapes_and_seed_centre():
    t = shape_masks("t").ignition
    assert t[50, 35] and t[35, 50] and t[65, 50] and not t[50, 65]
    assert seed_centre_m(shape_masks("circular").ignition) == (505.0, 505.0)
