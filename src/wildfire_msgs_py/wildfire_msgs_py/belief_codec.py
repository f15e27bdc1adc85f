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

from wildfire_msgs_py.codecs import (
    BELIEVED_ABOVE,
    FIRE_BURNING,
    FIRE_NOT_BURNING,
    grid_from_msg,
    grid_to_msg,
)


def _flat_inputs(believed: np.ndarray, probability: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    believed = np.ascontiguousarray(believed, dtype=bool)
    probability = np.ascontiguousarray(probability, dtype=np.float64)
    if believed.shape != probability.shape:
        raise ValueError(
            f"believed and probability must have one shape, got {believed.shape} and "
            f"{probability.shape}"
        )
    return believed.reshape(-1), probability.reshape(-1)


def belief_grid(believed: np.ndarray, probability: np.ndarray | None = None) -> np.ndarray:
    """The shared belief's int8 grid: the probability of burning in percent, rounded (half
    to even, in float64), but on the believed side of 50 (``> 50`` is believed burning,
    exactly, as the team decided on it). Without a probability (the paper's perfect disc):
    100 or 0."""
    if probability is None:
        believed = np.asarray(believed, dtype=bool)
        return np.where(believed, FIRE_BURNING, FIRE_NOT_BURNING).astype(np.int8)
    # Imported here: numba costs ~0.5 s of start-up, which only filtered beliefs need.
    from wildfire_msgs_py.percent_kernels import percent_grid

    flat_believed, flat_probability = _flat_inputs(believed, probability)
    percent = np.empty(np.shape(believed), dtype=np.int8)
    percent_grid(flat_believed, flat_probability, percent.reshape(-1))
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
    percent, on the believed side of 50 (``belief_probability(belief_grid(...))``, in one
    pass). The environment and the bag rebuild show the belief network this, so a network in
    a node sees exactly what it was trained on."""
    from wildfire_msgs_py.percent_kernels import published_grid

    flat_believed, flat_probability = _flat_inputs(believed, probability)
    shown = np.empty(np.shape(believed), dtype=np.float32)
    published_grid(flat_believed, flat_probability, shown.reshape(-1))
    return shown


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
