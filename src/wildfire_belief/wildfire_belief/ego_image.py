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
"""

from __future__ import annotations

import cv2
import numpy as np

from wildfire_sim.grid import CELL_SIZE_M

IMAGE_SIZE = 100
"""Pixels per side of the ego image (one map cell per pixel)."""
IMAGE_CENTRE = IMAGE_SIZE // 2
"""Pixel (row and column) where the aircraft sits."""


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
    age_s: np.ndarray,
    x_m: np.ndarray,
    y_m: np.ndarray,
    heading_rad: np.ndarray,
) -> np.ndarray:
    """Ego belief images of a batch of aircraft.

    ``burning`` (E, H, W), the probability of burning (bool or float in [0, 1]), and
    ``age_s`` (E, H, W) are the shared belief; poses are (E, N). Returns (E, N, 2, 100, 100)
    float32.
    """
    num_envs, num_aircraft = np.shape(x_m)
    out = np.empty((num_envs, num_aircraft, 2, IMAGE_SIZE, IMAGE_SIZE), dtype=np.float32)
    pixels = np.empty((IMAGE_SIZE, IMAGE_SIZE, 2), dtype=np.float32)
    for env in range(num_envs):
        source = np.stack([burning[env].astype(np.float32), age_s[env] / 255.0], axis=-1)
        source = np.ascontiguousarray(source, dtype=np.float32)
        for k in range(num_aircraft):
            matrix = ego_affine(x_m[env, k], y_m[env, k], heading_rad[env, k])
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


__all__ = ["IMAGE_CENTRE", "IMAGE_SIZE", "ego_affine", "ego_images"]
