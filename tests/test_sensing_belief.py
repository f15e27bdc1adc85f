"""Sensor image, visits, belief update and ego image on hand-built maps."""

from __future__ import annotations

import numpy as np

from wildfire_agent import sensor
from wildfire_belief.belief import SharedBelief, belief_iou
from wildfire_belief.ego_image import IMAGE_CENTRE, ego_images
from wildfire_belief.visits import visit_windows, visited_cells, window_values


def test_range_spacing_is_monotone_and_finer_near_the_aircraft():
    spacing = np.diff(sensor.RANGES_M)
    assert sensor.RANGES_M[0] == 10.0 and sensor.RANGES_M[-1] == 500.0
    assert (spacing > 0).all() and spacing[0] < spacing[-1]
    assert sensor.observe(np.zeros((1, 100, 100), bool), *np.full((3, 1, 1), 500.0)).shape == (
        1,
        1,
        30,
        40,
    )


def test_sensor_sees_a_fire_line_ahead_and_nothing_off_the_map():
    burning = np.zeros((1, 100, 100), dtype=bool)
    burning[0, 45:56, 60] = True  # a 110 m wall of fire 100 m east of the aircraft
    x, y = np.array([[505.0]]), np.array([[505.0]])
    image = sensor.observe(burning, x, y, np.array([[0.0]]))[0, 0]  # heading east
    bearings, ranges = np.nonzero(image)
    # Seen ahead: within about +/-30 degrees (bins 12..17), first hits ~100 m out.
    assert {14, 15} <= set(bearings.tolist()) <= set(range(12, 18))
    assert 95.0 <= sensor.RANGES_M[ranges].min() <= 110.0
    # Heading west, the same wall is behind: bins at the ends of the bearing axis.
    behind = sensor.observe(burning, x, y, np.array([[np.pi]]))[0, 0]
    assert {0, 29} <= set(np.nonzero(behind)[0].tolist()) <= {0, 1, 2, 27, 28, 29}
    # A map on fire everywhere reads 0 for samples beyond the map edge.
    # Near the west edge heading east: ahead is on the map, behind is not.
    full = sensor.observe(np.ones((1, 100, 100), bool), np.array([[5.0]]), y, np.array([[0.0]]))
    assert full[0, 0, 15].all() and not full[0, 0, 0].any()


def test_visits_are_cells_within_100_m():
    windows = visit_windows(np.array([[505.0]]), np.array([[505.0]]))
    assert windows.visited.sum() == 317  # cell centres within 10 cells of a centre
    assert windows.visited[0, 0, 10, 0] and not windows.visited[0, 0, 0, 0]
    corner = visit_windows(np.array([[3.0]]), np.array([[3.0]]))
    assert corner.row0[0, 0] == -10 and corner.visited[0, 0, :10].sum() == 0


def test_belief_reward_counts_newly_seen_fire_once():
    truth = np.zeros((1, 100, 100), dtype=bool)
    truth[0, 50, 45:56] = True  # 11 burning cells
    belief = SharedBelief(1)
    belief.reset([0], truth & (np.arange(100) < 48))  # cells 45..47 already believed
    # Two aircraft 20 m apart both see the whole strip: counted once.
    windows = visit_windows(np.array([[500.0, 520.0]]), np.array([[505.0, 505.0]]))
    env, cell = visited_cells(windows)
    belief.tick()
    reward = belief.visit(env, cell, truth.reshape(1, -1)[env, cell])
    assert reward.tolist() == [8]
    age = belief.age_s()[0]
    assert age[50, 50] == 0.0 and age[0, 0] == 255.0
    belief.tick()
    assert belief.age_s()[0, 50, 50] == np.float32(0.1)
    assert belief.visit(env, cell, truth.reshape(1, -1)[env, cell]).tolist() == [0]
    assert belief_iou(belief.burning, truth)[0] == 1.0


def test_window_values_match_the_grid():
    grid = np.arange(1, 10001).reshape(1, 100, 100)  # every cell different
    windows = visit_windows(np.array([[250.0]]), np.array([[730.0]]))
    r0, c0 = windows.row0[0, 0], windows.col0[0, 0]
    values = window_values(grid, windows)[0, 0]
    expected = np.where(windows.visited[0, 0], grid[0, r0 : r0 + 21, c0 : c0 + 21], 0)
    np.testing.assert_array_equal(values, expected)


def test_ego_image_is_centred_and_heading_aligned():
    burning = np.zeros((1, 100, 100), dtype=bool)
    burning[0, 60, 50] = True  # 100 m north of (505, 505)
    age = np.full((1, 100, 100), 51.0, dtype=np.float32)
    x, y = np.array([[505.0]]), np.array([[505.0]])
    north = ego_images(burning, age, x, y, np.array([[np.pi / 2]]))[0, 0]
    assert np.argwhere(north[0]).tolist() == [[IMAGE_CENTRE + 10, IMAGE_CENTRE]]
    east = ego_images(burning, age, x, y, np.array([[0.0]]))[0, 0]
    assert np.argwhere(east[0]).tolist() == [[IMAGE_CENTRE, IMAGE_CENTRE - 10]]  # on the left
    assert east[1, IMAGE_CENTRE, IMAGE_CENTRE] == np.float32(51.0 / 255.0)
    assert east[1, 0, 0] == 1.0 and east[0].max() == 1.0  # off the map: never seen, no fire
