"""One fire episode as the fire-simulator node runs it (no ROS): reset, decisions, end.

The same rules as ``wildfire_learning.env.WildfireVecEnv`` (which composes the same
``BatchedFire``): the fire resets from the seed and pre-burns ``preburn_steps`` fire steps;
each decision increments the counter and every ``DECISIONS_PER_FIRE_STEP``-th decision steps
the fire; after a fire step the episode is *terminated* when a burning cell lies within
``border_cells`` of the map edge, otherwise *truncated* once ``max_decisions`` are flown.
"""

from __future__ import annotations

import numpy as np

from wildfire_sim.fire import BatchedFire, FireParams
from wildfire_sim.shapes import Shape, shape_masks

DECISIONS_PER_FIRE_STEP = 25
"""2.5 s fire steps at 10 Hz decisions."""
DECISION_PERIOD_NS = 100_000_000
"""One decision is 0.1 s; tick ``k`` happens at ``k * DECISION_PERIOD_NS`` of sim time."""


def fire_at_border(burning: np.ndarray, border_cells: int) -> bool:
    """True when a cell of the (H, W) ``burning`` grid lies within ``border_cells`` of an edge."""
    height, width = burning.shape
    inner = burning[border_cells : height - border_cells, border_cells : width - border_cells]
    return bool(burning.sum() > inner.sum())


def fire_step_tick(tick: int) -> int:
    """Decision index of the fire step whose map holds at decision ``tick``."""
    return (tick // DECISIONS_PER_FIRE_STEP) * DECISIONS_PER_FIRE_STEP


def initial_fire(
    seed: int, shape: Shape | str, wind: tuple[float, float] = (0.0, 0.0)
) -> BatchedFire:
    """The fire of episode ``seed`` at ignition (before the pre-burn), one environment."""
    masks = shape_masks(Shape.parse(str(shape.value if isinstance(shape, Shape) else shape)))
    fire = BatchedFire(1)
    fire.reset([0], [seed], masks.ignition, masks.fuel, np.asarray(wind, dtype=np.float64))
    return fire


class FireEpisode:
    """A seeded fire stepped by decisions, with the episode-end rules of the environment."""

    def __init__(
        self,
        seed: int,
        shape: Shape | str,
        wind: tuple[float, float],
        *,
        max_decisions: int,
        preburn_steps: int = 30,
        border_cells: int = 6,
        params: FireParams | None = None,
    ) -> None:
        self.seed = int(seed)
        self.shape = Shape.parse(str(shape.value if isinstance(shape, Shape) else shape))
        self.wind = (float(wind[0]), float(wind[1]))
        self.max_decisions = int(max_decisions)
        self.border_cells = int(border_cells)
        masks = shape_masks(self.shape)
        self.fire = BatchedFire(1, params)
        self.fire.reset([0], [self.seed], masks.ignition, masks.fuel, np.asarray(self.wind))
        self.ignition_burning = self.fire.burning[0].copy()
        for _ in range(preburn_steps):
            self.fire.step()
        self.decisions = 0
        self.phase = "terminated" if fire_at_border(self.burning, self.border_cells) else "running"

    @property
    def burning(self) -> np.ndarray:
        """(H, W) bool truth."""
        return self.fire.burning[0]

    @property
    def fuel(self) -> np.ndarray:
        """(H, W) int8 fuel left."""
        return self.fire.fuel[0]

    @property
    def final(self) -> bool:
        return self.phase != "running"

    def advance(self) -> bool:
        """One decision; True when the fire stepped. Updates :attr:`phase`."""
        if self.final:
            raise RuntimeError("the episode has ended")
        self.decisions += 1
        stepped = self.decisions % DECISIONS_PER_FIRE_STEP == 0
        if stepped:
            self.fire.step()
            if fire_at_border(self.burning, self.border_cells):
                self.phase = "terminated"
        if self.phase == "running" and self.decisions >= self.max_decisions:
            self.phase = "truncated"
        return stepped


__all__ = [
    "DECISIONS_PER_FIRE_STEP",
    "DECISION_PERIOD_NS",
    "FireEpisode",
    "fire_at_border",
    "fire_step_tick",
    "initial_fire",
]
