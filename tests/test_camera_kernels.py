"""The camera world's compiled loops equal the numpy they replaced: the footprint search, run
for run (the stored camera-world results were flown with it), and the environment's reports,
report for report."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from wildfire_agent import camera
from wildfire_agent.camera import ALTITUDE_M, RANGE_M, WINDOW_HALF
from wildfire_agent.camera_view import BURNING, CLEAR, NOTHING
from wildfire_agent.dynamics import MAX_BANK_STEPS
from wildfire_belief import belief_kernels
from wildfire_belief.sensors import CAMERA_WINDOW, NUM_CAMERAS
from wildfire_belief.visits import cell_offset_m, within_radius
from wildfire_sim.grid import CELL_SIZE_M, PAPER_MAP

GRID_SIZE = PAPER_MAP.rows


def first_true(holds: Callable[[np.ndarray], np.ndarray], guess: np.ndarray, side: int):
    """The smallest column in [0, side] at which a monotone test holds, per entry."""
    j = np.clip(np.ceil(guess), 0, side).astype(np.int64)
    while True:
        back = (j > 0) & holds(np.maximum(j - 1, 0))
        if not back.any():
            break
        j -= back
    while True:
        forward = (j < side) & ~holds(np.minimum(j, side - 1))
        if not forward.any():
            return j
        j += forward


def numpy_runs(x_m, y_m, heading_rad, bank_steps):
    """The footprint runs as whole-array numpy (the former ``camera_windows``)."""
    half, side = WINDOW_HALF, CAMERA_WINDOW
    row = np.floor(y_m / CELL_SIZE_M).astype(np.int64)
    col = np.floor(x_m / CELL_SIZE_M).astype(np.int64)
    rows = row[..., None] + np.arange(-half, half + 1)
    dy = cell_offset_m(rows, y_m[..., None])
    col_west = (col - half)[..., None, None]
    x_b = x_m[..., None, None]

    def dx_at(j):
        return cell_offset_m(col_west + j, x_b)

    def column_of(dx):
        return (dx + x_b) / CELL_SIZE_M - 0.5 - col_west

    normals = camera._EDGE_NORMALS[bank_steps + MAX_BANK_STEPS]
    cos_h = np.cos(heading_rad)[..., None, None]
    sin_h = np.sin(heading_rad)[..., None, None]
    slope = (normals[..., 0] * cos_h - normals[..., 1] * sin_h)[..., None]
    north = normals[..., 0] * sin_h + normals[..., 1] * cos_h
    offset = north[..., None] * dy[..., None, None, :] - ALTITUDE_M * normals[..., 2, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        edge = -offset / slope
    keep_all = np.where(offset >= 0, np.inf, -np.inf)
    lower = np.where(slope > 0, edge, np.where(slope < 0, -np.inf, -keep_all)).max(axis=-2)
    upper = np.where(slope < 0, edge, np.where(slope > 0, np.inf, keep_all)).min(axis=-2)
    first = first_true(lambda j: dx_at(j) >= lower, column_of(lower), side)
    stop = first_true(lambda j: dx_at(j) > upper, column_of(upper), side)
    dy_b = dy[..., None, :]
    reach = np.sqrt(np.maximum(RANGE_M**2 - dy_b**2, 0.0))

    def within(j):
        return within_radius(dy_b, dx_at(j), RANGE_M)

    near_start = first_true(lambda j: (dx_at(j) >= 0) | within(j), column_of(-reach), side)
    near_stop = first_true(lambda j: (dx_at(j) > 0) & ~within(j), column_of(reach), side)
    first = np.maximum(np.maximum(first, near_start), np.clip(-col_west, 0, side))
    stop = np.minimum(np.minimum(stop, near_stop), np.clip(GRID_SIZE - col_west, 0, side))
    on_map = (rows >= 0) & (rows < GRID_SIZE)
    row_usable = within_radius(dy_b, np.zeros(1), RANGE_M) & on_map[..., None, :]
    return first, np.where(row_usable, np.maximum(stop, first), first)


def test_footprint_runs_equal_the_numpy_search() -> None:
    rng = np.random.default_rng(5)
    poses = 4000
    # Anywhere on and beyond the map, every bank; some positions on cell edges and centres
    # and some headings along the grid's axes and diagonals, where ties are likeliest.
    x = rng.uniform(-50.0, 1050.0, poses)
    y = rng.uniform(-50.0, 1050.0, poses)
    heading = rng.uniform(-7.0, 7.0, poses)
    bank = rng.integers(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1, poses)
    x[:800] = np.round(x[:800] / CELL_SIZE_M) * CELL_SIZE_M
    y[400:1200] = np.round(y[400:1200] / CELL_SIZE_M) * CELL_SIZE_M + 5.0
    heading[:400] = rng.integers(0, 8, 400) * np.pi / 4
    shape = (poses // 2, 2)
    x, y, heading, bank = (values.reshape(shape) for values in (x, y, heading, bank))
    windows = camera.camera_windows(x, y, heading, bank)
    first, stop = numpy_runs(x, y, heading, bank)
    np.testing.assert_array_equal(windows.runs.first, first)
    np.testing.assert_array_equal(windows.runs.stop, stop)
    assert windows.runs.counts().sum() > 1_000_000  # not vacuous: most poses see ~1 000 cells


def test_window_reports_equal_the_flips_of_each_aircraft() -> None:
    """The environment's one-pass reports equal ``report_flips`` (the nodes' path): the same
    cells, in the same order, with the same uniforms, truth and codes."""
    rng = np.random.default_rng(9)
    episodes, aircraft = 3, 2
    shape = (episodes, aircraft)
    x, y = rng.uniform(0.0, 1000.0, shape), rng.uniform(0.0, 1000.0, shape)
    heading = rng.uniform(-np.pi, np.pi, shape)
    bank = rng.integers(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1, shape)
    windows = camera.camera_windows(x, y, heading, bank)
    truth = rng.random((episodes, GRID_SIZE, GRID_SIZE)) < 0.4
    p = 0.3

    def streams() -> list[np.random.Generator]:
        return [np.random.default_rng(100 + k) for k in range(episodes * aircraft)]

    index, flips = camera.report_flips(windows.runs, streams(), p)
    e, n, c, i, j = index
    cells = (windows.row0[e, n] + i) * GRID_SIZE + windows.col0[e, n] + j
    values = truth.reshape(episodes, -1)[e, cells] ^ flips

    lead = (episodes * aircraft, NUM_CAMERAS, CAMERA_WINDOW)
    codes = np.full((*lead, CAMERA_WINDOW), NOTHING, np.uint8)
    env, cell, value, wrong = belief_kernels.window_reports(
        windows.runs.first.reshape(lead),
        windows.runs.stop.reshape(lead),
        windows.row0.reshape(-1),
        windows.col0.reshape(-1),
        np.repeat(np.arange(episodes), aircraft),
        truth.reshape(-1),
        camera.report_uniforms(windows.runs, streams()),
        p,
        GRID_SIZE,
        PAPER_MAP.cells,
        codes,
        CLEAR,
        BURNING,
    )
    np.testing.assert_array_equal(env, e)
    np.testing.assert_array_equal(cell, cells)
    np.testing.assert_array_equal(value, values)
    np.testing.assert_array_equal(wrong, flips)
    expected_codes = np.full(codes.shape, NOTHING, np.uint8)
    expected_codes[(e * aircraft + n, c, i, j)] = np.where(values, BURNING, CLEAR)
    np.testing.assert_array_equal(codes, expected_codes)
    assert cell.size > 1000 and 0 < wrong.mean() < 0.5  # not vacuous
