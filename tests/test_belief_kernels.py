"""The belief's faster per-decision code (compiled loops, one-array ages) equals the
whole-array numpy rules it replaced.

Each reference below is the numpy code that ran before the loops were compiled; the stored
camera-world results were flown with it, so equality here is what keeps them reproducible.
"""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_belief.belief import AGE_CAP_TICKS, TICKS_PER_S, age_seconds
from wildfire_belief.filtered_aggregator import score_decision
from wildfire_belief.filtered_belief import LogOddsBelief, neighbour_pressure
from wildfire_belief.window_runs import WindowRuns, run_cells
from wildfire_msgs_py.belief_codec import (
    BELIEVED_ABOVE,
    belief_grid,
    belief_probability,
    published_probability,
)
from wildfire_msgs_py.codecs import FIRE_BURNING

CELLS = 100 * 100


def numpy_update(belief: LogOddsBelief, env: np.ndarray, cell: np.ndarray, value: np.ndarray):
    """The dense-count update: net reports per cell, one step and one clip per counted cell."""
    flat = env * CELLS + cell
    belief.last_report.reshape(-1)[flat] = belief.now[env]
    log_odds = belief.log_odds.reshape(-1)
    net = np.bincount(flat, weights=np.where(value, 1.0, -1.0), minlength=log_odds.size)
    counted = np.flatnonzero(net)
    net = net[counted]
    weight = 2.0 * belief.max_log_odds if belief.p == 0.0 else belief.report_log_odds
    step = (np.sign(net) if belief.p == 0.0 else net) * weight
    bound = belief.max_log_odds
    log_odds[counted] = np.clip(log_odds[counted] + step, -bound, bound)


@pytest.mark.parametrize("p", [0.1, 0.0, 0.3])
def test_update_equals_the_dense_count(p: float) -> None:
    rng = np.random.default_rng(7)
    compiled, reference = LogOddsBelief(4, p), LogOddsBelief(4, p)
    for decision in range(40):
        # Few cells, many reports: duplicates, ties and clipping all occur.
        n = int(rng.integers(0, 3000))
        env = rng.integers(0, 4, n)
        cell = rng.integers(0, 200, n)
        value = rng.random(n) < rng.random()
        for belief in (compiled, reference):
            belief.tick()
        compiled.update(env, cell, value)
        numpy_update(reference, env, cell, value)
        if decision % 10 == 9:
            compiled.predict()
            reference.predict()
        np.testing.assert_array_equal(compiled.log_odds, reference.log_odds)
        np.testing.assert_array_equal(compiled.last_report, reference.last_report)
    assert not compiled._net.any(), "the scratch count must be left all zero"
    assert np.abs(compiled.log_odds).max() == compiled.max_log_odds  # the clip was reached


def numpy_run_cells(runs: WindowRuns):
    count = runs.counts().reshape(-1)
    run = np.repeat(np.arange(count.size), count)
    start = np.cumsum(count) - count
    column = runs.first.reshape(-1)[run] + (np.arange(int(count.sum())) - start[run])
    return np.unravel_index(run, runs.first.shape), column


@pytest.mark.parametrize("shape", [(61,), (3, 61), (5, 2, 4, 61), (2, 1, 3, 7)])
def test_run_cells_equals_numpy(shape: tuple[int, ...]) -> None:
    rng = np.random.default_rng(3)
    side = shape[-1]
    first = rng.integers(0, side + 1, shape)
    stop = np.minimum(first + rng.integers(0, 20, shape), side)
    index, column = run_cells(WindowRuns(first, stop))
    expected_index, expected_column = numpy_run_cells(WindowRuns(first, stop))
    assert len(index) == len(expected_index) == len(shape)
    for got, expected in zip(index, expected_index, strict=True):
        np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(column, expected_column)


def numpy_grid(believed: np.ndarray, probability: np.ndarray) -> np.ndarray:
    scaled = np.clip(probability, 0.0, 1.0)
    scaled *= FIRE_BURNING
    percent = np.rint(scaled, out=scaled).astype(np.int8)
    np.maximum(percent, np.int8(BELIEVED_ABOVE + 1), out=percent, where=believed)
    np.minimum(percent, np.int8(BELIEVED_ABOVE), out=percent, where=~believed)
    return percent


def test_published_percent_equals_numpy() -> None:
    rng = np.random.default_rng(11)
    log_odds = rng.uniform(-12.0, 12.0, (3, 100, 100))
    probability = 1.0 / (1.0 + np.exp(-log_odds))
    believed = log_odds > 0.0
    # Ties of the rounding (half to even), the clip, and beliefs against their probability.
    edges = np.array([0.125, 0.375, 0.5, 0.5, 0.7, 0.3, -0.2, 1.4])
    probability[0, 0, : edges.size] = edges
    believed[0, 0, : edges.size] = [0, 0, 1, 0, 0, 1, 0, 1]
    expected = numpy_grid(believed, probability)
    np.testing.assert_array_equal(belief_grid(believed, probability), expected)
    np.testing.assert_array_equal(
        published_probability(believed, probability), belief_probability(expected)
    )
    assert expected[0, 0, : edges.size].tolist() == [12, 38, 51, 50, 50, 51, 0, 100]


def test_score_decision_equals_the_rule_cell_by_cell() -> None:
    rng = np.random.default_rng(5)
    before, after, truth = (rng.random((6, 100, 100)) < 0.3 for _ in range(3))
    scored = rng.random((6, 100, 100)) < 0.2
    changed = ~before & after
    newly, alarms = changed & truth & ~scored, changed & ~truth
    expected_scored = scored | newly
    scores, false_alarms = score_decision(before, after, truth, scored)
    np.testing.assert_array_equal(scores, newly.sum(axis=(1, 2)))
    np.testing.assert_array_equal(false_alarms, alarms.sum(axis=(1, 2)))
    np.testing.assert_array_equal(scored, expected_scored)
    assert scores.min() > 0 and false_alarms.min() > 0  # not vacuous
    # One map: the aggregator's call.
    one = np.zeros((100, 100), bool)
    scores, false_alarms = score_decision(before[0], after[0], truth[0], one)
    assert scores.tolist() == [int((changed[0] & truth[0]).sum())]


def test_neighbour_pressure_equals_the_shifted_sum() -> None:
    """The compiled stencil sum equals the numpy sum of 24 shifted, weighted copies."""
    rng = np.random.default_rng(2)
    probability = np.where(rng.random((3, 100, 100)) < 0.2, rng.random((3, 100, 100)), 0.0)
    kernel = rng.random((3, 5, 5))
    padded = np.pad(probability, ((0, 0), (2, 2), (2, 2)))
    expected = np.zeros_like(probability)
    for i in range(5):
        for j in range(5):
            if (i, j) != (2, 2):
                expected += kernel[:, i, j, None, None] * padded[:, i : i + 100, j : j + 100]
    np.testing.assert_array_equal(neighbour_pressure(probability, kernel), expected)


def test_age_seconds_equals_the_float64_rule_for_every_age() -> None:
    """Every capped age, from every tick: float32 arithmetic equals the int64 difference
    divided in float64 and rounded to float32."""
    last = np.arange(-AGE_CAP_TICKS, 4001)  # never visited (-cap) up to now
    now = np.array([4000, 2600, 0])[:, None]
    expected = (np.minimum(now - last, AGE_CAP_TICKS) / TICKS_PER_S).astype(np.float32)
    got = age_seconds(now, last)
    assert got.dtype == np.float32 and got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)
    assert got.max() == AGE_CAP_TICKS / TICKS_PER_S
