"""Independent random streams derived from one episode seed.

An episode seed fixes everything random about an episode. It is split into named streams
with :class:`numpy.random.SeedSequence` spawn keys, so that, for example, the fire's random
numbers never depend on how many random numbers a policy drew, and one environment's
stream never depends on how many environments are batched with it. The simulator, the
training environment and the ROS nodes all derive their generators here.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np


class Stream(IntEnum):
    """Spawn-key roots of the streams of one episode."""

    FIRE = 0
    """Initial fuel and every ignition draw of the fire model."""
    SCENARIO = 1
    """Shape draw, wind draw and aircraft start poses."""
    AIRCRAFT = 2
    """Per-aircraft policy randomness (random policy, planner restarts, exploration)."""
    RADIO = 3
    """Per-link message loss of the radio model (``wildfire_belief.radio``)."""
    SENSOR = 4
    """Per-aircraft sensor noise: which reports flip (``wildfire_agent.camera``)."""
    WIND = 5
    """The team's wind filter: its particles' winds and resampling."""


def generator(seed: int, stream: Stream, *index: int) -> np.random.Generator:
    """A PCG64 generator for ``stream`` (optionally sub-indexed, e.g. by aircraft) of ``seed``."""
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    sequence = np.random.SeedSequence(int(seed), spawn_key=(int(stream), *index))
    return np.random.Generator(np.random.PCG64(sequence))


__all__ = ["Stream", "generator"]
