"""The belief as the network sees it: 2 x 100 x 100, centred and heading-aligned.

See docs/model.md, Shared belief.

Image pixel ``[i, j]`` shows the belief at the point ``(i - 50) * 10`` m ahead of the aircraft
and ``(j - 50) * 10`` m to its right: the aircraft sits at pixel (50, 50), rows run forward
("up" when drawn with origin at the bottom, as the map is), columns run to the right. So an
aircraft heading north sees the map itself, translated. Channels: the probability of burning
(0..1: the believed map, 0 or 1, under the paper's perfect disc) and age / 255 (0..1);
outside the map: burning 0, age 1 (never seen). Sampling is nearest-cell (OpenCV
``warpAffine`` with ``INTER_NEAREST``), so every pixel is one cell's value: a binary belief
stays binary.

On a field map an image reads only the cells around its aircraft: a window of
:data:`WINDOW_SPAN` cells a side that holds the image's rotated square, on each axis longer
than that (the paper's 100-cell map is warped whole, as it always was). Ages may then be
given as a function of the window (``AgeWindow``), so no map-sized age array is made.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from wildfire_sim.grid import CELL_SIZE_M

IMAGE_SIZE = 100
"""Pixels per side of the ego image (one map cell per pixel)."""
IMAGE_CENTRE = IMAGE_SIZE // 2
"""Pixel (row and column) where the aircraft sits."""
WINDOW_REACH = 72
"""Cells from the aircraft to the window's edge: the image's corners lie 50 sqrt 2 = 70.7
cells away, and nearest sampling reads at most one cell further."""
WINDOW_SPAN = 2 * WINDOW_REACH + 2
"""Side of the window an image reads; a map axis no longer than this is read whole."""

AgeWindow = Callable[[int, slice, slice], np.ndarray]
"""``age(env, rows, cols)``: the (h, w) float32 ages of one environment's window."""


def ego_affine(x_m: float, y_m: float, heading_rad: float) -> np.ndarray:
    """2 x 3 map from image pixel (column j, row i) to map cell coordinates (column, row).

    Map cell coordinates are continuous with cell (r, c)'s centre at (c, r).
    """
    cos_h, sin_h = np.cos(heading_rad), np.sin(heading_rad)
    # Pixel (j, i) is (i - 50) cells forward and (j - 50) cells right of the aircraft.
    # forward = (cos h, sin h), right = (sin h, -cos h) in (column, row) = (x, y) cells.
    u0 = x_m / CELL_SIZE_M - 0.5
    v0 = y_m / CELL_SIZE_M - 0.5
    c = IMAGE_CENTRE
    return np.array(
        [
            [sin_h, cos_h, u0 - c * sin_h - c * cos_h],
            [-cos_h, sin_h, v0 + c * cos_h - c * sin_h],
        ],
        dtype=np.float64,
    )


def ego_images(
    burning: np.ndarray,
    age_s: np.ndarray | AgeWindow,
    x_m: np.ndarray,
    y_m: np.ndarray,
    heading_rad: np.ndarray,
) -> np.ndarray:
    """Ego belief images of a batch of aircraft.

    ``burning`` (E, H, W), the probability of burning (bool or float in [0, 1]), and
    ``age_s`` (E, H, W), or a function of the window, are the shared belief; poses are
    (E, N). Returns (E, N, 2, 100, 100) float32.
    """
    num_envs, num_aircraft = np.shape(x_m)
    height, width = burning.shape[-2:]
    ages = age_s if callable(age_s) else lambda env, rows, cols: age_s[env, rows, cols]
    out = np.empty((num_envs, num_aircraft, 2, IMAGE_SIZE, IMAGE_SIZE), dtype=np.float32)
    pixels = np.empty((IMAGE_SIZE, IMAGE_SIZE, 2), dtype=np.float32)
    whole = height <= WINDOW_SPAN and width <= WINDOW_SPAN
    for env in range(num_envs):
        if whole:
            source = _source(burning[env], ages(env, slice(None), slice(None)))
        for k in range(num_aircraft):
            matrix = ego_affine(x_m[env, k], y_m[env, k], heading_rad[env, k])
            if not whole:
                rows = _axis_window(y_m[env, k] / CELL_SIZE_M, height)
                cols = _axis_window(x_m[env, k] / CELL_SIZE_M, width)
                if rows.start == rows.stop or cols.start == cols.stop:
                    out[env, k, 0], out[env, k, 1] = 0.0, 1.0  # far off the map: never seen
                    continue
                source = _source(burning[env, rows, cols], ages(env, rows, cols))
                # The window's origin: an integer shift of the map's coordinates (exact).
                matrix[0, 2] -= cols.start
                matrix[1, 2] -= rows.start
            cv2.warpAffine(
                source,
                matrix,
                (IMAGE_SIZE, IMAGE_SIZE),
                dst=pixels,
                flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=(0.0, 1.0, 0.0, 0.0),
            )
            out[env, k] = pixels.transpose(2, 0, 1)
    return out


def _source(burning: np.ndarray, age_s: np.ndarray) -> np.ndarray:
    """The two channels OpenCV samples, (h, w, 2) float32."""
    source = np.empty((*burning.shape, 2), dtype=np.float32)
    source[..., 0] = burning
    np.divide(age_s, np.float32(255.0), out=source[..., 1], casting="unsafe")
    return source


def _axis_window(centre: float, size: int) -> slice:
    """The window's cells along an axis around the aircraft's cell ``centre``, clipped."""
    low = int(np.floor(centre)) - WINDOW_REACH
    return slice(min(max(low, 0), size), min(max(low + WINDOW_SPAN, 0), size))


__all__ = [
    "IMAGE_CENTRE",
    "IMAGE_SIZE",
    "WINDOW_REACH",
    "WINDOW_SPAN",
    "AgeWindow",
    "ego_affine",
    "ego_images",
]
