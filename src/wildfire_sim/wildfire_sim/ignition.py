"""The fire of an episode at ignition, without torch.

Stepping a fire needs the batched convolution of :mod:`wildfire_sim.fire` (torch), but its
start does not: the initial fuel is a seeded draw and the first burning cells are the
ignition cells with fuel. Both rules are written here once; :meth:`BatchedFire.reset
<wildfire_sim.fire.BatchedFire.reset>` calls them, and so do the processes that only need the
ignition (the belief aggregator, the run monitor, the agents' radio replicas), which then
start without loading torch (about 1.5 s of CPU each, measured here).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from wildfire_sim.defaults import EPISODE_DEFAULTS
from wildfire_sim.fuel_map import FuelMap
from wildfire_sim.grid import MapGeometry
from wildfire_sim.landscape import PAPER_LANDSCAPE, Landscape
from wildfire_sim.seeding import Stream, generator
from wildfire_sim.shapes import Shape
from wildfire_sim.spread import FireParams


def draw_fuel(
    rng: np.random.Generator,
    shape: tuple[int, int],
    fuel_mask: np.ndarray,
    params: FireParams,
    fuel_map: FuelMap | None = None,
) -> np.ndarray:
    """Initial fuel (H, W) int8: uniform integers in [fuel_min, fuel_max] (or the fuel map's
    per-cell range), 0 outside ``fuel_mask``, drawn from ``rng`` (the fire's stream)."""
    if fuel_map is None:
        fuel = rng.integers(params.fuel_min, params.fuel_max + 1, size=shape, dtype=np.int8)
    else:
        fuel = rng.integers(fuel_map.low, fuel_map.high.astype(np.int16) + 1, dtype=np.int16)
        fuel = fuel.astype(np.int8)
    fuel[~np.asarray(fuel_mask, dtype=bool)] = 0
    return fuel


def first_burning(ignition: np.ndarray, fuel: np.ndarray) -> np.ndarray:
    """The cells burning at ignition: ignition cells without fuel do not burn."""
    return np.asarray(ignition, dtype=bool) & (fuel > 0)


class Ignition(NamedTuple):
    burning: np.ndarray
    """(H, W) bool cells burning at ignition."""
    fuel: np.ndarray
    """(H, W) int8 initial fuel."""


def ignite(
    seed: int,
    shape: Shape | str,
    ground: Landscape | MapGeometry = PAPER_LANDSCAPE,
    params: FireParams | None = None,
    border_cells: int = EPISODE_DEFAULTS.border_cells,
) -> Ignition:
    """Episode ``seed``'s fire of ``shape`` at ignition on ``ground`` (a map alone: the
    paper's fuel on it), as :func:`wildfire_sim.episode.initial_fire` starts it (the wind
    does not enter; ``border_cells`` keeps seeded ignitions off the edge band)."""
    if isinstance(ground, MapGeometry):
        ground = Landscape(ground)
    # str of a Shape is its value
    masks = ground.start(Shape.parse(str(shape)), int(seed), border_cells)
    rng = generator(int(seed), Stream.FIRE)
    fuel = draw_fuel(rng, ground.geometry.shape, masks.fuel, params or FireParams(), ground.fuel)
    return Ignition(first_burning(masks.ignition, fuel), fuel)


__all__ = ["Ignition", "draw_fuel", "first_burning", "ignite"]
