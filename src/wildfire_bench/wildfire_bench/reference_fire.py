"""A straightforward single-environment numpy fire step: the yardstick of the batched model.

This is how the model is usually first written (and how the authors' scripts read): one
100 x 100 grid, the ignition probability as a product over the 24 neighbour offsets, one
uniform per cell. It is only used to measure how much the batched model gains.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from wildfire_sim.fire import spread_kernel


class ReferenceFire:
    """One fire, stepped with plain numpy, float64 probabilities."""

    def __init__(
        self, seed: int, ignition: np.ndarray, fuel_mask: np.ndarray, wind: npt.ArrayLike
    ) -> None:
        self.rng = np.random.default_rng(seed)
        self.fuel = self.rng.integers(15, 21, size=ignition.shape).astype(np.int64)
        self.fuel[~fuel_mask] = 0
        self.burning = ignition & (self.fuel > 0)
        self.kernel = spread_kernel(np.asarray(wind, dtype=np.float64))

    def step(self) -> None:
        n = self.burning.shape[0]
        padded = np.pad(self.burning.astype(np.float64), 2)
        survival = np.ones((n, n))
        for i in range(5):
            for j in range(5):
                if i == 2 and j == 2:
                    continue
                survival *= 1.0 - self.kernel[i, j] * padded[i : i + n, j : j + n]
        p_ignite = np.where(self.fuel > 0, 1.0 - survival, 0.0)
        ignites = ~self.burning & (self.rng.random((n, n)) < p_ignite)
        self.fuel = np.where(self.burning, np.maximum(self.fuel - 1, 0), self.fuel)
        self.burning = (self.burning & (self.fuel > 0)) | ignites
