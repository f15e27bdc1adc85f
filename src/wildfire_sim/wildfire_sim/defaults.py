"""The default scenario of an episode, in a module light enough for every command line.

:mod:`wildfire_sim.episode` re-exports it; the CLIs import it from here so that building a
parser does not load the fire model (and torch).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EpisodeDefaults:
    """Default scenario of an episode; fields are named as the fire simulator's parameters."""

    seed: int = 0
    """Episode seed (fuel and fire randomness)."""
    shape: str = "circular"
    """Ignition shape."""
    wind_x: float = 0.0
    """Fixed dimensionless wind towards east (a single run; evaluation draws it per seed)."""
    wind_y: float = 0.0
    """Fixed dimensionless wind towards north."""
    max_wind: float = 0.8
    """Bound of each wind component when it is drawn per seed (the training range)."""
    duration_s: float = 400.0
    """Flight time limit."""
    preburn_steps: int = 30
    """Fire steps before the aircraft start."""
    border_cells: int = 6
    """The episode ends when fire comes this close to the map edge."""


EPISODE_DEFAULTS = EpisodeDefaults()
"""The one copy of the episode defaults (environment, fire simulator, CLIs)."""


__all__ = ["EPISODE_DEFAULTS", "EpisodeDefaults"]
