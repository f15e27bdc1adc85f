"""The shared belief on the wire: ``/wildfire/belief`` as an OccupancyGrid in percent.

A cell holds the team's probability of burning in whole percent, rounded but kept on the
believed side of 50, so ``> 50`` is exactly what the team believes burning (the paper's
perfect disc: 100 or 0). The aggregator encodes with :func:`belief_to_msg`; an agent decodes
the probability (:func:`belief_probability`), and the environment and the bag rebuild show
their belief networks the same rounding (:func:`published_probability`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from wildfire_msgs_py.codecs import FIRE_BURNING, FIRE_NOT_BURNING, grid_from_msg, grid_to_msg

BELIEVED_ABOVE = FIRE_BURNING // 2
"""A shared-belief cell is believed burning when its value is above this (percent)."""


def belief_grid(believed: np.ndarray, probability: np.ndarray | None = None) -> np.ndarray:
    """The shared belief's int8 grid: the probability of burning in percent, rounded, but
    on the believed side of 50 (``> 50`` is believed burning, exactly, as the team decided
    on it). Without a probability (the paper's perfect disc): 100 or 0."""
    believed = np.asarray(believed, dtype=bool)
    if probability is None:
        return np.where(believed, FIRE_BURNING, FIRE_NOT_BURNING).astype(np.int8)
    # In place: fresh map-sized temporaries cost more in page faults than the arithmetic.
    scaled = np.clip(probability, 0.0, 1.0)
    scaled *= FIRE_BURNING
    percent = np.rint(scaled, out=scaled).astype(np.int8)
    np.maximum(percent, np.int8(BELIEVED_ABOVE + 1), out=percent, where=believed)
    np.minimum(percent, np.int8(BELIEVED_ABOVE), out=percent, where=~believed)
    return percent


def belief_to_msg(
    believed: np.ndarray,
    stamp: Any = 0,
    *,
    probability: np.ndarray | None = None,
    message_class: Any = None,
) -> Any:
    """Shared belief -> grid (:func:`belief_grid`)."""
    grid = belief_grid(believed, probability)
    return grid_to_msg(grid, stamp, message_class=message_class)


def belief_from_msg(msg: Any) -> np.ndarray:
    """Grid -> bool believed burning (value above 50)."""
    return grid_from_msg(msg) > BELIEVED_ABOVE


def belief_probability(grid: np.ndarray) -> np.ndarray:
    """The probability of burning of a shared-belief grid (:func:`belief_grid`), float32 in
    [0, 1]: what a belief network's image shows. Under the disc, 1.0 or 0.0."""
    probability = np.asarray(grid).astype(np.float32)
    probability /= np.float32(FIRE_BURNING)
    return probability


def published_probability(believed: np.ndarray, probability: np.ndarray) -> np.ndarray:
    """A filtered belief's probability of burning as ``/wildfire/belief`` carries it: in whole
    percent, on the believed side of 50 (``belief_probability(belief_grid(...))``). The
    environment and the bag rebuild show the belief network this, so a network in a node
    sees exactly what it was trained on."""
    return belief_probability(belief_grid(believed, probability))


def believed_burning(probability: np.ndarray) -> np.ndarray:
    """Believed burning: probability above one half (bool in, bool out too)."""
    return np.asarray(probability) > 0.5


__all__ = [
    "BELIEVED_ABOVE",
    "belief_from_msg",
    "belief_grid",
    "belief_probability",
    "belief_to_msg",
    "believed_burning",
    "published_probability",
]
