"""Filtered beliefs for noisy reports (log-odds and Kalman forms) and the wind particle filter."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wildfire_agent import camera
from wildfire_belief.belief import AGE_CAP_TICKS
from wildfire_belief.filtered_belief import (
    IGNITION_PROBABILITY,
    PIXEL_ERROR,
    LogOddsBelief,
    burn_survival,
    log_survival_kernel,
)
from wildfire_belief.kalman_belief import (
    KALMAN_INITIAL_VARIANCE,
    KALMAN_Q,
    KALMAN_R,
    KalmanBelief,
)
from wildfire_belief.wind_filter import WindFilter
from wildfire_sim.fire import BatchedFire, FireParams, spread_kernel
from wildfire_sim.shapes import shape_masks

N = 100
CELL = 50 * N + 50  # flat index of cell (50, 50)


def reports(cells: list[int], values: list[bool], env: int = 0):
    """(env, cell, value) arrays of a batch of reports."""
    return (
        np.full(len(cells), env, dtype=np.int64),
        np.asarray(cells, dtype=np.int64),
        np.asarray(values, dtype=bool),
    )


def empty_start(belief: LogOddsBelief | KalmanBelief, num_envs: int = 1) -> None:
    belief.reset(np.arange(num_envs), np.zeros((N, N), dtype=bool))


def test_default_flip_probability_is_the_cameras():
    assert PIXEL_ERROR == camera.PIXEL_ERROR


@pytest.mark.parametrize("form", [LogOddsBelief, KalmanBelief])
def test_repeated_true_reports_make_a_cell_believed_and_false_ones_clear_it(form):
    belief = form(1)
    empty_start(belief)
    assert belief.probability()[0, 50, 50] < 0.01 and not belief.believed().any()
    history = []
    for _ in range(6):
        belief.update(*reports([CELL], [True]))
        history.append(belief.probability()[0, 50, 50])
    assert np.all(np.diff(history) > 0) and history[-1] > 0.5
    assert belief.believed()[0, 50, 50] and belief.believed().sum() == 1
    for _ in range(12):
        belief.update(*reports([CELL], [False]))
    assert belief.probability()[0, 50, 50] < 0.5 and not belief.believed().any()


def test_one_false_report_never_raises_a_false_alarm():
    for form in (LogOddsBelief(1), KalmanBelief(1)):
        empty_start(form)
        form.update(*reports([CELL], [True]))
        assert not form.believed().any()


@pytest.mark.parametrize("p", [0.1, 0.25])
def test_log_odds_update_is_bayes_rule(p):
    belief = LogOddsBelief(1, p)
    empty_start(belief)
    prior = 0.3
    belief.log_odds[0, 50, 50] = math.log(prior / (1 - prior))
    values = [True, True, False, True]
    belief.update(*reports([CELL] * 2, values[:2]))
    belief.update(*reports([CELL] * 2, values[2:]))
    like_burning = math.prod((1 - p) if v else p for v in values)
    like_not = math.prod(p if v else (1 - p) for v in values)
    expected = prior * like_burning / (prior * like_burning + (1 - prior) * like_not)
    assert belief.probability()[0, 50, 50] == pytest.approx(expected, rel=1e-12)


def test_duplicate_reports_each_count():
    once, twice, sequential = LogOddsBelief(1), LogOddsBelief(1), LogOddsBelief(1)
    for belief in (once, twice, sequential):
        empty_start(belief)
    once.update(*reports([CELL], [True]))
    twice.update(*reports([CELL, CELL], [True, True]))
    sequential.update(*reports([CELL], [True]))
    sequential.update(*reports([CELL], [True]))
    step = math.log((1 - PIXEL_ERROR) / PIXEL_ERROR)
    assert twice.log_odds[0, 50, 50] - once.log_odds[0, 50, 50] == pytest.approx(step)
    np.testing.assert_allclose(twice.log_odds, sequential.log_odds, rtol=0, atol=1e-12)
    # Opposite reports of one batch cancel exactly.
    mixed = LogOddsBelief(1)
    empty_start(mixed)
    before = mixed.log_odds.copy()
    mixed.update(*reports([CELL, CELL], [True, False]))
    np.testing.assert_array_equal(mixed.log_odds, before)


def test_log_odds_are_clipped_so_a_confirmed_cell_flips_back_quickly():
    belief = LogOddsBelief(1)
    empty_start(belief)
    belief.update(*reports([CELL] * 200, [True] * 200))
    assert belief.log_odds[0, 50, 50] == belief.max_log_odds
    flips = 0
    while belief.believed()[0, 50, 50]:
        belief.update(*reports([CELL], [False]))
        flips += 1
    assert flips == 5  # CLIP_REPORTS = 4.5 reports' worth: the fifth contrary report flips


def test_perfect_reports_fix_the_cell():
    belief = LogOddsBelief(1, p=0.0)
    empty_start(belief)
    belief.update(*reports([CELL], [True]))
    assert belief.probability()[0, 50, 50] > 1 - 1e-5
    belief.update(*reports([CELL], [False]))
    assert belief.probability()[0, 50, 50] < 1e-5


def test_kalman_update_equals_sequential_scalar_updates():
    belief = KalmanBelief(1)
    empty_start(belief)
    belief.predict()
    belief.update(*reports([CELL, CELL, CELL], [True, False, True]))
    x, var = 0.0, KALMAN_INITIAL_VARIANCE + KALMAN_Q
    for z in (1.0, 0.0, 1.0):
        gain = var / (var + KALMAN_R)
        x, var = x + gain * (z - x), (1 - gain) * var
    assert belief.mean[0, 50, 50] == pytest.approx(x, rel=1e-12)
    assert belief.variance[0, 50, 50] == pytest.approx(var, rel=1e-12)
    assert belief.variance[0, 0, 0] == pytest.approx(KALMAN_INITIAL_VARIANCE + KALMAN_Q)
    assert (belief.mean >= 0).all() and (belief.mean <= 1).all()


def test_process_term_ignites_the_neighbours_of_a_fire_and_not_far_cells():
    belief = LogOddsBelief(1)
    block = np.zeros((N, N), dtype=bool)
    block[48:53, 48:53] = True
    belief.reset([0], block)
    before = belief.probability()[0]
    history = [before[50, 53]]
    for _ in range(6):
        belief.predict()
        history.append(belief.probability()[0, 50, 53])
    assert np.all(np.diff(history) > 0) and history[-1] > 0.5
    assert 0.01 < belief.probability()[0, 50, 54] < history[-1]
    # Beyond the stencil's reach in six steps nothing moves off the floor.
    after = belief.probability()[0]
    assert after[50, 80] == before[50, 80] and after[10, 10] == before[10, 10]


def test_wind_pushes_the_process_downwind():
    belief = LogOddsBelief(1)
    belief.set_wind([0], np.array([0.8, 0.0]))
    block = np.zeros((N, N), dtype=bool)
    block[48:53, 48:53] = True
    belief.reset([0], block)
    for _ in range(5):
        belief.predict()
    probability = belief.probability()[0]
    assert probability[50, 55] > 0.1 and probability[50, 55] > 10 * probability[50, 45]


def test_an_unobserved_burning_cell_burns_out_on_the_fuel_model_schedule():
    belief = LogOddsBelief(1)
    seed = np.zeros((N, N), dtype=bool)
    seed[50, 50] = True
    belief.reset([0], seed)
    believed = []
    for _ in range(22):
        belief.predict()
        believed.append(bool(belief.believed()[0, 50, 50]))
    # Fuel 15..20: certainly burning for 14 steps, certainly out after 20.
    assert all(believed[:14]) and not any(believed[20:])
    geometric = LogOddsBelief(1, age_hazard=False)
    geometric.reset([0], seed)
    start = geometric.probability()[0, 50, 50]
    geometric.predict()
    assert geometric.probability()[0, 50, 50] < start


def test_a_cell_seen_burning_to_the_end_then_out_does_not_reignite():
    belief = LogOddsBelief(1)
    seed = np.zeros((N, N), dtype=bool)
    seed[50, 50] = True
    belief.reset([0], seed)
    for _ in range(17):  # seen burning through the ages where cells burn out
        belief.predict()
        belief.update(*reports([CELL] * 3, [True] * 3))
    belief.update(*reports([CELL] * 6, [False] * 6))
    assert not belief.believed()[0, 50, 50] and belief.spent[0, 50, 50] > 0.99
    # Fresh fire all around it and around an unburnt cell alike: only the unburnt one ignites.
    ring = np.zeros((N, N), dtype=bool)
    ring[47:54, 47:54] = ring[47:54, 67:74] = True
    ring[50, 50] = ring[50, 70] = False
    belief.log_odds[0][ring] = belief.max_log_odds
    belief.burn_age[0][ring] = 0.0
    for _ in range(3):
        belief.predict()
    probability = belief.probability()[0]
    assert probability[50, 50] < 0.01 and probability[50, 70] > 0.5


def test_ages_count_ticks_since_the_last_report_and_saturate():
    belief = LogOddsBelief(2)
    empty_start(belief, 2)
    assert (belief.age_ticks() == AGE_CAP_TICKS).all()
    belief.tick()
    belief.update(*reports([CELL], [True], env=1))
    for _ in range(7):
        belief.tick()
    ages = belief.age_ticks()
    assert ages[1, 50, 50] == 7 and ages[0, 50, 50] == AGE_CAP_TICKS
    assert belief.age_s()[1, 50, 50] == pytest.approx(0.7)
    belief.tick([0])
    assert belief.age_ticks()[1, 50, 50] == 7
    for _ in range(AGE_CAP_TICKS + 5):
        belief.tick()
    assert belief.age_ticks()[1, 50, 50] == AGE_CAP_TICKS


@pytest.mark.parametrize("form", [LogOddsBelief, KalmanBelief])
def test_reset_restarts_only_the_given_environments(form):
    belief = form(2)
    seed = shape_masks("circular").ignition
    belief.reset([0, 1], seed)
    np.testing.assert_array_equal(belief.believed()[0], seed)
    assert belief.probability()[0][seed].min() == pytest.approx(IGNITION_PROBABILITY)
    belief.tick()
    belief.update(*reports([0, CELL], [True, False], env=0))
    belief.update(*reports([0], [True], env=1))
    kept = belief.probability()[0].copy()
    belief.reset([1], np.zeros((N, N), dtype=bool))
    np.testing.assert_array_equal(belief.probability()[0], kept)
    assert not belief.believed()[1].any()
    assert (belief.age_ticks()[1] == AGE_CAP_TICKS).all() and belief.age_ticks()[0, 0, 0] == 0


def test_reset_fuel_mask_and_preburn():
    masks = shape_masks("arc")
    belief = LogOddsBelief(1)
    belief.reset([0], masks.ignition, masks.fuel, preburn_steps=10)
    assert (belief.spent[0][~masks.fuel] == 1.0).all()
    probability = belief.probability()[0]
    # The pre-burn spreads the seed south (fuel) but not into the fuel-less north.
    assert probability[46, 50] > 0.5 and probability[~masks.fuel].max() < 0.01


def test_an_environment_does_not_depend_on_its_batch():
    seed = shape_masks("circular").ignition
    alone, batch = LogOddsBelief(1), LogOddsBelief(3)
    alone.set_wind([0], np.array([0.3, -0.2]))
    batch.set_wind([0, 1, 2], np.array([[0.0, 0.5], [0.3, -0.2], [-0.7, 0.1]]))
    alone.reset([0], seed)
    batch.reset([0, 1, 2], seed)
    for step in range(4):
        cells = np.arange(4700, 5300, 3) + step
        values = cells % 2 == 0
        alone.update(np.zeros(cells.size, np.int64), cells, values)
        batch.update(
            np.concatenate([np.full(cells.size, 1), [0, 2]]),
            np.r_[cells, 1, 2],
            np.r_[values, True, True],
        )
        alone.predict()
        batch.predict()
    np.testing.assert_array_equal(alone.log_odds[0], batch.log_odds[1])


def test_bad_reports_and_parameters_are_refused():
    belief = LogOddsBelief(1)
    with pytest.raises(ValueError):
        belief.update(np.array([0]), np.array([N * N]), np.array([True]))
    with pytest.raises(ValueError):
        belief.update(np.array([1]), np.array([0]), np.array([True]))
    with pytest.raises(ValueError):
        belief.update(np.array([0, 0]), np.array([0]), np.array([True]))
    with pytest.raises(ValueError):
        LogOddsBelief(1, p=0.5)
    with pytest.raises(ValueError):
        WindFilter(4, np.random.default_rng(0), p=0.0)


def test_fire_model_tables():
    survival = burn_survival(FireParams())
    assert survival[:15].tolist() == [1.0] * 15 and survival[20] == 0.0
    assert survival[16] == pytest.approx(4 / 6)
    wind = np.array([0.4, -0.3])
    np.testing.assert_allclose(log_survival_kernel(wind), -np.log1p(-spread_kernel(wind)))


def run_wind_filter(seed: int, steps: int, reports_per_step: int = 3) -> WindFilter:
    """A wind filter following a synthetic fire with wind (0.6, 0) through noisy reports of
    the band of rows 20..79, ``reports_per_step`` reports of each cell per fire step."""
    masks = shape_masks("circular")
    truth = BatchedFire(1)
    truth.reset([0], [seed], masks.ignition, masks.fuel, np.array([0.6, 0.0]))
    wind_filter = WindFilter(40, np.random.default_rng(seed), PIXEL_ERROR)
    wind_filter.reset(masks.ignition, masks.fuel)
    noise = np.random.default_rng(1000 + seed)
    cells = np.arange(20 * N, 80 * N)
    for _ in range(steps):
        truth.step()
        wind_filter.step()
        for _ in range(reports_per_step):
            flips = noise.random(cells.size) < PIXEL_ERROR
            wind_filter.observe(cells, truth.burning[0].reshape(-1)[cells] ^ flips)
    return wind_filter


def test_wind_filter_estimate_moves_to_the_true_wind():
    # Seeds 0..11 all pass (wx from 0.38 to 0.75); seed 0 is a typical one (0.49).
    wind_filter = run_wind_filter(seed=0, steps=20)
    wx, wy = wind_filter.wind_estimate()
    assert wx > 0.3 and abs(wx - 0.6) < abs(wx - 0.0) and abs(wy) < 0.3
    probability = wind_filter.probability()
    assert probability.shape == (N, N) and 0.0 <= probability.min() <= probability.max() <= 1.0
    assert 1.0 <= wind_filter.effective_sample_size() <= 40.0


def test_wind_filter_is_bit_reproducible():
    first, second = run_wind_filter(seed=5, steps=6), run_wind_filter(seed=5, steps=6)
    np.testing.assert_array_equal(first.wind_estimate(), second.wind_estimate())
    np.testing.assert_array_equal(first.particles.wind, second.particles.wind)
    np.testing.assert_array_equal(first.log_weights, second.log_weights)
    np.testing.assert_array_equal(first.probability(), second.probability())
    other = run_wind_filter(seed=6, steps=6)
    assert not np.array_equal(first.particles.wind, other.particles.wind)
