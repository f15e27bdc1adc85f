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
    IGNITION = 6
    """Where ``--ignitions K`` lights its seeded blocks."""


def generator(seed: int, stream: Stream, *index: int) -> np.random.Generator:
    """A PCG64 generator for ``stream`` (optionally sub-indexed, e.g. by aircraft) of ``seed``."""
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    sequence = np.random.SeedSequence(int(seed), spawn_key=(int(stream), *index))
    return np.random.Generator(np.random.PCG64(sequence))


# SplitMix64's constants (Steele, Lea and Flood 2014): a bijective, well-mixing finaliser.
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def _mix(x: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser, elementwise on uint64 (wrapping arithmetic)."""
    x = (x ^ (x >> np.uint64(30))) * _MIX1
    x = (x ^ (x >> np.uint64(27))) * _MIX2
    return x ^ (x >> np.uint64(31))


def cell_uniforms(seed: np.ndarray, step: np.ndarray, cell: np.ndarray) -> np.ndarray:
    """Counter-based uniforms in [0, 1), one per (seed, fire step, cell index), float64.

    Each number is a hash of its three counters only (SplitMix64 applied to each in turn),
    so it does not depend on which other cells are drawn, in what order or in what cut of the
    map: the fire of a field map can be stepped on its active region alone. Streams of
    different seeds are independent in the sense of the hash's avalanche; this is the
    "hash of the three" that the counter-based generators of the literature (Philox,
    Threefry) do with more rounds.
    """
    with np.errstate(over="ignore"):
        key = _mix(np.asarray(seed, dtype=np.uint64) * _GOLDEN + np.uint64(Stream.FIRE))
        key = _mix(key ^ (np.asarray(step, dtype=np.uint64) + _GOLDEN))
        key = _mix(key ^ (np.asarray(cell, dtype=np.uint64) * _GOLDEN))
    # The top 53 bits give every double of [0, 1) on a 2**-53 lattice.
    return (key >> np.uint64(11)).astype(np.float64) * (1.0 / 2**53)


__all__ = ["Stream", "cell_uniforms", "generator"]
