"""A policy of your own: fly to the fire the team has not seen for longest.

Fly it with ``wildfire eval --policy examples/stalest_fire_policy.py:StalestFirePolicy`` (or in
``wildfire run`` and ``wildfire report``). It is a vector policy (docs/policies.md): from
its belief image it picks the believed-burning cell that is nearest once each second of
age counts as ``metres_per_second`` metres, and banks toward it; over it, the next one is
picked, so the aircraft circles the fire front revisiting its stalest part. Each aircraft
decides from its own row alone, which is what lets an agent node fly it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

PIXEL_M = 10.0
"""Metres per pixel of the belief image: the aircraft at pixel (50, 50), rows run forward,
columns to its right."""
MAX_BANK_STEPS = 10
"""The bank limit, 50 degrees, in 5 degree steps."""


class StalestFirePolicy:
    """Bank toward the believed fire that is nearest, counting age as distance."""

    observation = "belief"

    def __init__(self, metres_per_second: float = 4.0) -> None:
        self.metres_per_second = metres_per_second
        offsets = (np.arange(100) - 50) * PIXEL_M
        self.forward_m, self.right_m = np.meshgrid(offsets, offsets, indexing="ij")
        self.range_m = np.hypot(self.forward_m, self.right_m)

    def reset(self, env: Any) -> None:
        """Nothing to reset: the policy keeps no state between decisions."""

    def act(self, env: Any, observations: dict[str, np.ndarray]) -> np.ndarray:
        image = observations["image"]  # (E, N, 2, 100, 100)
        burning, age_s = image[:, :, 0] > 0.5, image[:, :, 1] * 255.0
        cost = np.where(burning, self.range_m - self.metres_per_second * age_s, np.inf)
        cost = cost.reshape(*cost.shape[:2], -1)
        target = cost.argmin(axis=-1)
        # Bearing of the target, counter-clockwise from the nose (to the left positive).
        bearing = np.arctan2(-self.right_m.flat[target], self.forward_m.flat[target])
        wanted = np.clip(np.rint(bearing / (np.pi / 2) * MAX_BANK_STEPS), -10, 10)
        wanted = np.where(np.isfinite(cost.min(axis=-1)), wanted, 0)  # none believed: level
        # Bank left (+5 degrees, action 1) while below the wanted bank, else right.
        return (env.aircraft.bank_steps < wanted).astype(np.int64)
