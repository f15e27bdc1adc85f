"""The fire model's parameters and its spread rule, without torch.

``P(s, s') = min(1, w / (spread_constant * d^2))`` (see :mod:`wildfire_sim.fire`) is written
here once, in numpy: the batched fire (:mod:`wildfire_sim.fire`, on torch) quantises it into its
convolution kernel, and the filtered belief's fire models (``wildfire_belief``) use it as it is.
A process that only configures a world or filters a belief (the ``wildfire run`` launcher, the
aggregator) then starts without loading torch, which costs about 1.4 s a process.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wildfire_sim.errors import FireConfigError

STENCIL_RADIUS = 2
"""Cells further than this (in row or column) never ignite each other."""
MAX_SPREAD_PROBABILITY = 0.99
"""Cap on P(s, s') so that 24 quantised terms stay exactly representable in float32."""


@dataclass(frozen=True)
class FireParams:
    """Parameters of the fire model (defaults: the paper and the authors' scripts)."""

    fuel_min: int = 15
    """Smallest initial fuel of a cell (integer, inclusive)."""
    fuel_max: int = 20
    """Largest initial fuel of a cell (integer, inclusive)."""
    burn_rate: int = 1
    """Fuel a burning cell consumes per fire step."""
    spread_constant: float = 22.0
    """Divisor of the spread probability: P = min(1, w / (spread_constant * d^2))."""
    step_period_s: float = 2.5
    """Simulated seconds per fire step."""

    def validate(self) -> FireParams:
        """Return self, or raise :class:`FireConfigError` naming the bad parameter."""
        if not 0 <= self.fuel_min <= self.fuel_max <= 127:
            raise FireConfigError(
                f"fuel_min/fuel_max: expected 0 <= fuel_min <= fuel_max <= 127, "
                f"got {self.fuel_min}/{self.fuel_max}"
            )
        if self.burn_rate < 1:
            raise FireConfigError(f"burn_rate: expected an integer >= 1, got {self.burn_rate}")
        if not self.spread_constant > 0:
            raise FireConfigError(f"spread_constant: expected > 0, got {self.spread_constant}")
        if not self.step_period_s > 0:
            raise FireConfigError(f"step_period_s: expected > 0, got {self.step_period_s}")
        return self


def validate_wind(wind: np.ndarray) -> np.ndarray:
    """Wind array (..., 2) as float64, each component in [-1, 1]."""
    wind = np.asarray(wind, dtype=np.float64)
    if wind.shape[-1:] != (2,) or not np.all(np.isfinite(wind)) or np.any(np.abs(wind) > 1.0):
        raise FireConfigError(f"wind: expected (wx, wy) with each in [-1, 1], got {wind.tolist()}")
    return wind


def spread_kernel(wind: np.ndarray, spread_constant: float = 22.0) -> np.ndarray:
    """P(s, s') for the 5 x 5 source offsets around a target, per wind: shape (..., 5, 5).

    Entry ``[i, j]`` is the probability that a burning source at row offset ``i - 2`` and
    column offset ``j - 2`` from the target ignites it (0 at the centre).
    """
    wind = validate_wind(wind)
    offsets = np.arange(-STENCIL_RADIUS, STENCIL_RADIUS + 1)
    d_row, d_col = np.meshgrid(offsets, offsets, indexing="ij")
    distance_sq = (d_row**2 + d_col**2).astype(np.float64)
    # The direction from source to target is minus the source's offset; x is the column.
    ux, uy = -np.sign(d_col), -np.sign(d_row)
    w = np.maximum(0.0, 1.0 + wind[..., 0, None, None] * ux + wind[..., 1, None, None] * uy)
    with np.errstate(divide="ignore", invalid="ignore"):
        probability = np.where(distance_sq > 0, w / (spread_constant * distance_sq), 0.0)
    return np.minimum(probability, 1.0)


__all__ = [
    "MAX_SPREAD_PROBABILITY",
    "STENCIL_RADIUS",
    "FireParams",
    "spread_kernel",
    "validate_wind",
]
