"""What the observation approach makes of its own cameras' reports: images and rewards.

Under camera sensing the ``obs`` approach does not see the true fire. It sees the four
images its cameras took this decision, and it is rewarded from what they reported.

Report codes
------------
An aircraft's reports of one decision are kept as codes in its four camera windows
(``camera.CameraWindows``, (..., 4, 61, 61) uint8): ``NOTHING`` (0) where the camera did not
see the cell, ``CLEAR`` (1) where it reported the cell not burning, ``BURNING`` (2) where it
reported it burning (:func:`report_codes`).

Images
------
Camera i's image is ``PIXELS_Y`` x ``PIXELS_X`` (30 x 20): row 0 is the far edge of the
image (its +y side, forward at bank 0), column 0 its +x side (toward the left wing at roll
0). A pixel shows the report of the cell its centre ray hits on the ground, as
``code / 2``: 1 reported burning, 0.5 reported clear, 0 nothing reported (the ray misses
the ground within range, leaves the map, or hits a cell whose centre the camera's rule did
not count as seen, at the footprint's ragged edge). So a pixel is made from exactly one
report, and pixels over the same cell show the same (noisy) value: near the aircraft a cell
spans about 2 x 2 pixels, far away a pixel about 1.5 cells. Zero is "nothing", as the
network's zero padding is.

The pixel rays are fixed in the body frame; the bank (a whole number of 5-degree steps)
only tilts them, so their ground offsets (forward, left) from the aircraft are tabled once
per bank, and a pose turns and shifts them (:func:`camera_images`).

Rewards (the observation reward's terms, from the reports only)
----------------------------------------------------------------
* ``r1 = -lambda1 * d``: distance to the nearest cell the cameras show burning, capped at
  500 m. One report in ten is wrong, so a single burning report is no fire: a cell counts
  when it was reported burning and most reports of its 3 x 3 neighbourhood (all cameras)
  say burning. In clear country about one cell in a thousand passes by chance (five or
  more of nine reports flipped), against about one in ten without the vote.
* ``r2 = -f_clear``: the fraction of the decision's reports that say clear, in [0, 1] (1
  when nothing was seen): point the cameras at the fire. The disc's r2 counts clear cells
  under the aircraft, which no camera sees (the footprints start ~35 m ahead).
* ``r3`` and ``r4`` are the disc's: bank and proximity (``rewards.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wildfire_agent.camera import (
    ALTITUDE_M,
    FOCAL_LENGTH_MM,
    PIXELS_X,
    PIXELS_Y,
    RANGE_M,
    SENSOR_X_MM,
    SENSOR_Y_MM,
    camera_axes,
)
from wildfire_agent.dynamics import BANK_STEP_RAD, MAX_BANK_STEPS, AircraftState
from wildfire_agent.rewards import ObservationRewardWeights, proximity_sum
from wildfire_belief.sensors import CAMERA_WINDOW, NUM_CAMERAS
from wildfire_belief.visits import cell_offset_m
from wildfire_msgs_py.codecs import VisitWindow
from wildfire_sim.grid import CELL_SIZE_M

NOTHING, CLEAR, BURNING = 0, 1, 2
"""Report codes of a camera window's cells."""
IMAGE_SHAPE = (NUM_CAMERAS, PIXELS_Y, PIXELS_X)
"""(C, H, W) of the observation approach's image under camera sensing."""
IMAGE_SCALE = 2.0
"""A pixel is ``code / IMAGE_SCALE``; the replay stores ``pixel * IMAGE_SCALE``, exactly."""
FIRE_VOTE = 3
"""Side of the neighbourhood whose reports must mostly say burning for r1 to count a cell."""


def report_codes(seen: np.ndarray, reported: np.ndarray) -> np.ndarray:
    """Codes (..., 4, 61, 61) uint8 from the footprints ``seen`` and the reported burning
    values (``camera.noisy_reports``; False where not seen)."""
    seen = np.asarray(seen, dtype=bool)
    return (seen.astype(np.uint8) + (seen & np.asarray(reported, dtype=bool))).astype(np.uint8)


def window_codes(
    reports: Sequence[Sequence[VisitWindow]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each aircraft's camera windows of one decision, as published (one per camera) ->
    codes (N, 4, 61, 61) and the windows' origin (N,) row0 and col0."""
    codes = [
        report_codes(
            np.stack([window.visited for window in own]),
            np.stack([window.burning for window in own]),
        )
        for own in reports
    ]
    row0 = np.array([own[0].row0 for own in reports], dtype=np.int64)
    col0 = np.array([own[0].col0 for own in reports], dtype=np.int64)
    return np.stack(codes), row0, col0


def _pixel_offsets() -> tuple[np.ndarray, np.ndarray]:
    """Ground offsets (forward, left) in metres of every pixel's centre ray, per bank step,
    (21, 4, 30, 20, 2), and whether the ray meets the ground within range, (21, 4, 30, 20).

    The ray of pixel (row, column) is ``a + (x / f) h + (y / f) v`` with (x, y) the pixel
    centre on the sensor in mm: where the footprint rule's ``f (r . h) / (r . a)`` is x.
    """
    a, h, v = np.moveaxis(camera_axes(), 1, 0)  # each (4, 3) in (f, l, u)
    pitch_x, pitch_y = SENSOR_X_MM / PIXELS_X, SENSOR_Y_MM / PIXELS_Y
    x_mm = SENSOR_X_MM / 2 - (np.arange(PIXELS_X) + 0.5) * pitch_x
    y_mm = SENSOR_Y_MM / 2 - (np.arange(PIXELS_Y) + 0.5) * pitch_y
    rays = (
        a[:, None, None, :]
        + (x_mm / FOCAL_LENGTH_MM)[None, None, :, None] * h[:, None, None, :]
        + (y_mm / FOCAL_LENGTH_MM)[None, :, None, None] * v[:, None, None, :]
    )  # (4, 30, 20, 3)
    bank = np.arange(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1) * BANK_STEP_RAD
    cos_b = np.cos(bank)[:, None, None, None]
    sin_b = np.sin(bank)[:, None, None, None]
    forward = np.broadcast_to(rays[..., 0], (bank.size, *rays.shape[:-1]))
    # (f, l, u) -> level frame (f, s, z), as camera._edge_normals turns the bank.
    left = rays[..., 1] * cos_b + rays[..., 2] * sin_b
    up = -rays[..., 1] * sin_b + rays[..., 2] * cos_b
    with np.errstate(divide="ignore"):
        reach = np.where(up < 0, ALTITUDE_M / -np.where(up < 0, up, -1.0), 0.0)
    offsets = np.stack([forward * reach, left * reach], axis=-1)
    # A cell seen is within 300 m; a ray meeting the ground further out hits no seen cell.
    hits = (up < 0) & (np.hypot(offsets[..., 0], offsets[..., 1]) <= RANGE_M + CELL_SIZE_M)
    return np.where(hits[..., None], offsets, 0.0), hits


_PIXEL_OFFSETS, _PIXEL_HITS = _pixel_offsets()


def camera_images(
    codes: np.ndarray, row0: np.ndarray, col0: np.ndarray, pose: AircraftState
) -> np.ndarray:
    """The four camera images (..., 4, 30, 20) float32 of aircraft at ``pose`` (fields (...))
    from their report ``codes`` (..., 4, 61, 61) in windows whose south-west cell is
    (``row0``, ``col0``) (``camera.camera_windows`` of the same pose)."""
    bank = np.asarray(pose.bank_steps) + MAX_BANK_STEPS
    offsets, hits = _PIXEL_OFFSETS[bank], _PIXEL_HITS[bank]  # (..., 4, 30, 20, (2))
    expand = (...,) + (None,) * 3
    cos_h = np.cos(pose.heading_rad)[expand]
    sin_h = np.sin(pose.heading_rad)[expand]
    forward, left = offsets[..., 0], offsets[..., 1]
    x = np.asarray(pose.x_m)[expand] + forward * cos_h - left * sin_h
    y = np.asarray(pose.y_m)[expand] + forward * sin_h + left * cos_h
    row = np.floor(y / CELL_SIZE_M).astype(np.int64) - np.asarray(row0)[expand]
    col = np.floor(x / CELL_SIZE_M).astype(np.int64) - np.asarray(col0)[expand]
    inside = hits & (row >= 0) & (row < CAMERA_WINDOW) & (col >= 0) & (col < CAMERA_WINDOW)
    flat = np.where(inside, row * CAMERA_WINDOW + col, 0)
    lead = flat.shape[:-3]
    codes = np.asarray(codes).reshape(*lead, NUM_CAMERAS, CAMERA_WINDOW * CAMERA_WINDOW)
    pixels = np.take_along_axis(codes, flat.reshape(*lead, NUM_CAMERAS, -1), axis=-1)
    pixels = np.where(inside, pixels.reshape(flat.shape), NOTHING)
    return (pixels / np.float32(IMAGE_SCALE)).astype(np.float32)


def _box_sums(counts: np.ndarray, side: int) -> np.ndarray:
    """Sums of (..., H, W) integer counts over each cell's ``side`` x ``side`` neighbourhood
    (zero beyond the edges): along the rows, then the columns."""
    half = side // 2
    padded = np.pad(counts, [(0, 0)] * (counts.ndim - 2) + [(half, half), (half, half)])
    height, width = counts.shape[-2:]
    rows = sum(padded[..., dr : dr + height, :] for dr in range(1, side))
    rows = rows + padded[..., :height, :]
    total = sum(rows[..., :, dc : dc + width] for dc in range(1, side))
    return np.asarray(total + rows[..., :, :width], dtype=np.int32)


def camera_fire_terms(
    codes: np.ndarray,
    row0: np.ndarray,
    col0: np.ndarray,
    pose: AircraftState,
    weights: ObservationRewardWeights,
) -> np.ndarray:
    """``r1 + r2`` (...,) float64 from each aircraft's report codes (see the module docstring)."""
    codes = np.asarray(codes)
    burning_reports = (codes == BURNING).sum(axis=-3, dtype=np.int32)  # (..., 61, 61)
    reports = (codes != NOTHING).sum(axis=-3, dtype=np.int32)
    votes_burning = _box_sums(burning_reports, FIRE_VOTE)
    votes = _box_sums(reports, FIRE_VOTE)
    fire = (burning_reports > 0) & (2 * votes_burning > votes)
    cells = np.arange(CAMERA_WINDOW)
    dx = cell_offset_m(np.asarray(col0)[..., None] + cells, np.asarray(pose.x_m)[..., None])
    dy = cell_offset_m(np.asarray(row0)[..., None] + cells, np.asarray(pose.y_m)[..., None])
    squared = dy[..., :, None] ** 2 + dx[..., None, :] ** 2
    nearest = np.sqrt(np.where(fire, squared, np.inf).min(axis=(-2, -1)))
    r1 = -weights.distance * np.minimum(nearest, weights.max_distance_m)
    total = reports.sum(axis=(-2, -1))
    clear = total - burning_reports.sum(axis=(-2, -1))
    r2 = -np.where(total > 0, clear / np.maximum(total, 1), 1.0)
    return r1 + r2


def camera_rewards(
    codes: np.ndarray,
    row0: np.ndarray,
    col0: np.ndarray,
    pose: AircraftState,
    weights: ObservationRewardWeights,
) -> np.ndarray:
    """The observation reward r1 + r2 + r3 + r4 under camera sensing, (E, N) float64 from
    (E, N) poses and their report codes (E, N, 4, 61, 61)."""
    return (
        camera_fire_terms(codes, row0, col0, pose, weights)
        - weights.bank * pose.bank_rad**2
        - weights.proximity * proximity_sum(pose.x_m, pose.y_m, weights.proximity_scale_m)
    )


__all__ = [
    "BURNING",
    "CLEAR",
    "FIRE_VOTE",
    "IMAGE_SCALE",
    "IMAGE_SHAPE",
    "NOTHING",
    "camera_fire_terms",
    "camera_images",
    "camera_rewards",
    "report_codes",
    "window_codes",
]
