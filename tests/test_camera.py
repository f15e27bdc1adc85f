"""The four cameras (wildfire_agent.camera): footprints against a plain reimplementation of
the rule, their layout at bank 0 and in a bank, the pixel noise, and `wildfire sensor`."""

from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from wildfire_agent.camera import (
    CAMERA_WINDOW,
    camera_cells,
    camera_windows,
    noisy_reports,
    window_values,
)

WILDFIRE = [str(Path(sys.executable).with_name("wildfire"))]

# The spec, written out again by hand (not imported), for the reference below.
ALTITUDE = 200.0
ROLLS_DEG = (40.0, 13.0, -13.0, -40.0)
PITCH_DEG = 30.0
FOCAL_MM, HALF_X_MM, HALF_Y_MM = 50.0, 12.0, 18.0
RANGE = 300.0
CELL, CELLS = 10.0, 100

POSITIONS = [(505.0, 505.0), (503.7, 488.2), (40.0, 960.0), (975.0, 130.0)]
HEADINGS_DEG = [0.0, 90.0, 217.0]
BANKS_DEG = [0, 20, -20, 50, -50]
POSES = [
    (x, y, heading, bank)
    for (x, y), heading, bank in itertools.product(POSITIONS, HEADINGS_DEG, BANKS_DEG)
]


def reference_footprints(
    x: float, y: float, heading_deg: float, bank_deg: float
) -> list[set[tuple[int, int]]]:
    """The cells each camera sees, by the rule of the spec, one cell at a time."""
    psi, phi, theta = math.radians(heading_deg), math.radians(bank_deg), math.radians(PITCH_DEG)
    forward = (math.cos(psi), math.sin(psi), 0.0)
    level_left = (-math.sin(psi), math.cos(psi), 0.0)
    left = tuple(
        math.cos(phi) * s - math.sin(phi) * z for s, z in zip(level_left, (0, 0, 1), strict=True)
    )
    up = tuple(
        math.sin(phi) * s + math.cos(phi) * z for s, z in zip(level_left, (0, 0, 1), strict=True)
    )

    def world(f: float, l_: float, u: float) -> tuple[float, ...]:
        """World vector of body components (f, l, u)."""
        return tuple(f * a + l_ * b + u * c for a, b, c in zip(forward, left, up, strict=True))

    cameras = []
    for roll_deg in ROLLS_DEG:
        roll = math.radians(roll_deg)
        axis = world(
            math.sin(theta), math.cos(theta) * math.sin(roll), -math.cos(theta) * math.cos(roll)
        )
        image_x = world(0.0, math.cos(roll), math.sin(roll))
        image_y = world(
            math.cos(theta), -math.sin(theta) * math.sin(roll), math.sin(theta) * math.cos(roll)
        )
        cameras.append((axis, image_x, image_y))

    seen: list[set[tuple[int, int]]] = [set() for _ in cameras]
    for row in range(CELLS):
        for col in range(CELLS):
            dx, dy = (col + 0.5) * CELL - x, (row + 0.5) * CELL - y
            if dx * dx + dy * dy > RANGE * RANGE:
                continue
            for camera, (axis, image_x, image_y) in enumerate(cameras):
                along = dx * axis[0] + dy * axis[1] - ALTITUDE * axis[2]
                if along <= 0:
                    continue
                across_x = dx * image_x[0] + dy * image_x[1] - ALTITUDE * image_x[2]
                across_y = dx * image_y[0] + dy * image_y[1] - ALTITUDE * image_y[2]
                if (
                    abs(FOCAL_MM * across_x / along) <= HALF_X_MM
                    and abs(FOCAL_MM * across_y / along) <= HALF_Y_MM
                ):
                    seen[camera].add((row, col))
    return seen


def batch_footprints(poses: list[tuple[float, float, float, int]]) -> list[list[set]]:
    """The module's cells for all poses, from one call on a (E, N)-shaped batch."""
    x, y, heading, bank = (np.array(values) for values in zip(*poses, strict=True))
    shape = (len(poses) // 5, 5)
    windows = camera_windows(
        x.reshape(shape),
        y.reshape(shape),
        np.deg2rad(heading).reshape(shape),
        (bank // 5).astype(np.int64).reshape(shape),
    )
    found = []
    for k in range(len(poses)):
        e, n = divmod(k, shape[1])
        row0, col0 = windows.row0[e, n], windows.col0[e, n]
        found.append(
            [
                {(int(row0 + i), int(col0 + j)) for i, j in zip(*np.nonzero(seen), strict=True)}
                for seen in windows.seen[e, n]
            ]
        )
    return found


def jaccard(a: set, b: set) -> float:
    return 1.0 if not a and not b else len(a & b) / len(a | b)


def body_coordinates(x: float, y: float, heading_deg: float, cells: np.ndarray) -> np.ndarray:
    """(forward, left) metres of cell centres ((K, 2) rows and columns) from the aircraft."""
    psi = math.radians(heading_deg)
    dx = (cells[:, 1] + 0.5) * CELL - x
    dy = (cells[:, 0] + 0.5) * CELL - y
    return np.stack(
        [dx * math.cos(psi) + dy * math.sin(psi), -dx * math.sin(psi) + dy * math.cos(psi)], -1
    )


def test_footprints_match_a_cell_by_cell_reference() -> None:
    assert len(POSES) % 5 == 0
    vectorised = batch_footprints(POSES)
    worst = 1.0
    for pose, found in zip(POSES, vectorised, strict=True):
        expected = reference_footprints(*pose)
        for camera in range(4):
            score = jaccard(found[camera], expected[camera])
            assert score >= 0.98, (pose, camera, score)
            worst = min(worst, score)
        if pose[:2] == POSITIONS[1] and pose[3] == 0:
            assert all(len(cells) > 200 for cells in expected), pose  # not vacuous
    assert worst == 1.0  # in fact identical: no cell centre sits on a field-of-view edge


@pytest.mark.parametrize("heading_deg", [0.0, 217.0])
def test_bank_zero_footprints_lie_ahead_left_to_right_nearly_disjoint(heading_deg: float) -> None:
    x, y = 503.7, 488.2
    cells = camera_cells(x, y, math.radians(heading_deg), 0)
    sets = [set(map(tuple, camera.tolist())) for camera in cells]
    mean_left = []
    for camera in cells:
        assert len(camera) > 200
        forward, left = body_coordinates(x, y, heading_deg, camera).T
        # One band ahead: from ~35 m (the 10 degree near edge) to the 300 m range.
        assert forward.min() > 30 and forward.max() <= 300
        mean_left.append(left.mean())
    # Camera 0 (roll +40, toward the left wing) leftmost, camera 3 rightmost; symmetric.
    assert mean_left[0] > mean_left[1] > 0 > mean_left[2] > mean_left[3]
    assert mean_left[0] == pytest.approx(-mean_left[3], abs=5)
    # Only neighbours share cells, and few (measured: 41 to 51 cells, <= 20% of an inner
    # camera's ~255: the side edges of the rolled cameras diverge with range).
    for i, j in itertools.combinations(range(4), 2):
        shared = len(sets[i] & sets[j])
        if j - i > 1:
            assert shared == 0, (i, j)
        else:
            assert shared <= 0.25 * min(len(sets[i]), len(sets[j])), (i, j, shared)
    union = set().union(*sets)
    assert sum(map(len, sets)) - len(union) <= 0.2 * len(union)


@pytest.mark.parametrize("bank_deg", [20, 50])
def test_a_bank_swings_the_footprints_out_of_the_turn(bank_deg: int) -> None:
    x, y, heading_deg = 503.7, 488.2, 217.0

    def mean_left(bank: int) -> tuple[list[float], float]:
        cells = camera_cells(x, y, math.radians(heading_deg), bank // 5)
        lefts = [body_coordinates(x, y, heading_deg, camera)[:, 1] for camera in cells]
        return [float(left.mean()) if left.size else math.nan for left in lefts], float(
            np.concatenate(lefts).mean()
        )

    level, level_all = mean_left(0)
    assert abs(level_all) < 5
    # A left bank (positive, a left turn) aims the rig to the right, and vice versa.
    left_bank, left_bank_all = mean_left(bank_deg)
    right_bank, right_bank_all = mean_left(-bank_deg)
    assert left_bank_all < -40 and right_bank_all > 40
    for camera in range(4):
        if not math.isnan(left_bank[camera]):
            assert left_bank[camera] < level[camera] - 20
        if not math.isnan(right_bank[camera]):
            assert right_bank[camera] > level[camera] + 20


def test_flip_rate_is_p() -> None:
    rng = np.random.default_rng(3)
    burning = rng.random((1, CELLS, CELLS)) < 0.5
    sensor_rng = np.random.default_rng(11)
    flipped = total = 0
    flipped_each_way = [0, 0]
    for _ in range(40):
        pose = rng.uniform(200, 800, 2)
        windows = camera_windows(
            pose[:1].reshape(1, 1),
            pose[1:].reshape(1, 1),
            rng.uniform(-np.pi, np.pi, (1, 1)),
            rng.integers(-10, 11, (1, 1)),
        )
        truth = window_values(burning, windows)
        reports = noisy_reports(truth, windows.seen, [sensor_rng], p=0.1)
        assert not reports[~windows.seen].any()
        true_seen = np.broadcast_to(truth[:, :, None], windows.seen.shape)[windows.seen]
        wrong = reports[windows.seen] != true_seen
        flipped += int(wrong.sum())
        total += wrong.size
        flipped_each_way[0] += int((wrong & ~true_seen).sum())
        flipped_each_way[1] += int((wrong & true_seen).sum())
    assert total > 20_000
    assert abs(flipped / total - 0.1) <= 0.01
    assert min(flipped_each_way) > 0.3 * flipped  # both false fires and missed fires


def test_reports_are_bit_identical_alone_or_in_a_batch() -> None:
    rng = np.random.default_rng(5)
    num_envs, num_aircraft = 3, 2
    burning = rng.random((num_envs, CELLS, CELLS)) < 0.4
    shape = (num_envs, num_aircraft)
    x, y = rng.uniform(100, 900, shape), rng.uniform(100, 900, shape)
    heading, bank = rng.uniform(-np.pi, np.pi, shape), rng.integers(-10, 11, shape)
    windows = camera_windows(x, y, heading, bank)
    seeds = [100 + k for k in range(num_envs * num_aircraft)]
    batch = noisy_reports(
        window_values(burning, windows), windows.seen, [np.random.default_rng(s) for s in seeds]
    )
    for e, n in itertools.product(range(num_envs), range(num_aircraft)):
        alone_pose = (field[e : e + 1, n : n + 1] for field in (x, y, heading, bank))
        one = camera_windows(*alone_pose)
        own_rng = np.random.default_rng(seeds[e * num_aircraft + n])
        alone = noisy_reports(window_values(burning[e : e + 1], one), one.seen, [own_rng])
        assert np.array_equal(alone[0, 0], batch[e, n])
        # Exactly one uniform per (camera, seen cell), camera-major then by flat cell index.
        seen = one.seen[0, 0]
        uniforms = np.random.default_rng(seeds[e * num_aircraft + n]).random(int(seen.sum()))
        truth = window_values(burning[e : e + 1], one)[0, 0]
        expected = np.zeros_like(seen)
        expected[seen] = np.broadcast_to(truth, seen.shape)[seen].astype(bool) ^ (uniforms < 0.1)
        assert np.array_equal(alone[0, 0], expected)
        assert (
            own_rng.random()
            == np.random.default_rng(seeds[e * num_aircraft + n]).random(int(seen.sum()) + 1)[-1]
        )


def test_window_shape_and_bank_checks() -> None:
    windows = camera_windows(
        np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3), int)
    )
    assert windows.seen.shape == (2, 3, 4, CAMERA_WINDOW, CAMERA_WINDOW)
    with pytest.raises(ValueError):
        camera_windows(np.zeros(1), np.zeros(1), np.zeros(1), np.array([11]))
    with pytest.raises(ValueError):
        camera_windows(np.zeros(1), np.zeros(1), np.zeros(1), np.array([0.0]))


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*WILDFIRE, "sensor", *args], capture_output=True, text=True, timeout=120, check=False
    )


def test_sensor_json_matches_the_module() -> None:
    result = run_cli("--x", "612.5", "--y", "333.3", "--heading", "217", "--bank", "-20", "--json")
    assert result.returncode == 0, result.stderr
    cameras = json.loads(result.stdout)["cameras"]
    expected = camera_cells(612.5, 333.3, float(np.deg2rad(217.0)), -4)
    assert cameras == [camera.tolist() for camera in expected]
    assert len(cameras) == 4 and all(cameras)
    for camera in cameras:
        assert camera == sorted(camera)  # row-major ascending


def test_sensor_text_and_png(tmp_path: Path) -> None:
    png = tmp_path / "footprints.png"
    result = run_cli("--x", "505", "--y", "505", "--heading", "0", "--bank", "0", "--png", str(png))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 5 and lines[-1] == f"wrote {png}"
    counts = [len(cells) for cells in camera_cells(505.0, 505.0, 0.0, 0)]
    assert [int(line.split(": ")[1].split()[0]) for line in lines[:4]] == counts
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize("bank", ["7", "55", "-52.5", "ten"])
def test_sensor_refuses_a_bad_bank(bank: str) -> None:
    result = run_cli("--x", "500", "--y", "500", "--heading", "0", "--bank", bank)
    assert result.returncode == 2
    assert result.stdout == ""
    assert len(result.stderr.strip().splitlines()) == 1
    assert "--bank" in result.stderr
