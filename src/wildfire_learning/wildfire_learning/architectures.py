"""Q-network architectures to train: the paper's, and a faster one for the belief image.

* ``paper`` — :class:`wildfire_learning.q_network.QNetwork` on the full image (docs/model.md,
  Q-network).
* ``fast`` — the same network behind a 2 x 2 average pool of the input image, so the
  100 x 100 belief image is seen at 50 x 50 (one pixel = 20 m; burning becomes the burning
  fraction of the 2 x 2 block, age its mean). Its convolutions cost ~4x less; on this CPU the
  paper's belief network trains at ~0.5 iteration/s, far from the paper's 24 h budget.
* ``lite`` — the same behind a 4 x 4 average pool (25 x 25, one pixel = 40 m, still finer
  than the 100 m visit radius): ~4x cheaper again, the belief network that trains within
  the 2-3 hour budget here.

The pool lives inside the module, so a ``fast``/``lite`` policy file takes the same
2 x 100 x 100 input and the agent nodes need no change. For the 30 x 40 sensor image they
are not offered: the paper's network is already fast there.
"""

from __future__ import annotations

import torch
from torch import nn

from wildfire_agent.approaches import IMAGE_SHAPES, Approach, image_shape
from wildfire_agent.pairwise import STATE_SIZE
from wildfire_learning.errors import LearningError
from wildfire_learning.q_network import QNetwork

ARCHITECTURES = ("paper", "fast", "lite")
POOLING = {"fast": 2, "lite": 4}
"""Average-pool factor of the input image of each downsampled architecture."""
STATE_SHAPE_K2 = (1, STATE_SIZE)
"""Pairwise-state shape of one ownship with one other aircraft (training uses 2 aircraft)."""


class DownsampledQNetwork(nn.Module):
    """:class:`QNetwork` on a ``factor`` x ``factor`` average-pooled image (same signature)."""

    def __init__(
        self, image_shape: tuple[int, int, int], factor: int = 2, dueling: bool = False
    ) -> None:
        super().__init__()
        channels, height, width = image_shape
        self.pool = nn.AvgPool2d(factor)
        self.q = QNetwork((channels, height // factor, width // factor), dueling=dueling)

    def forward(self, images: torch.Tensor, states: torch.Tensor) -> torch.Tensor:
        return self.q(self.pool(images), states)


def build_q_network(
    approach: str, arch: str = "paper", sensor: str = "disc", dueling: bool = False
) -> nn.Module:
    """A freshly initialised Q-network for ``approach`` (obs/belief) and ``arch``, taking
    the approach's images in a world sensed by ``sensor``, with a dueling head if ``dueling``."""
    if approach not in IMAGE_SHAPES:
        raise LearningError(f"approach: expected obs or belief, got {approach!r}")
    if arch not in ARCHITECTURES:
        raise LearningError(f"arch: expected one of {ARCHITECTURES}, got {arch!r}")
    shape = image_shape(approach, sensor)
    if arch in POOLING:
        if approach != Approach.BELIEF:
            raise LearningError(f"arch {arch}: only for the belief approach (obs is already fast)")
        return DownsampledQNetwork(shape, POOLING[arch], dueling)
    return QNetwork(shape, dueling=dueling)


def network_name(approach: str, arch: str, dueling: bool) -> str:
    """How messages name a network: ``obs/paper``, ``belief/lite+dueling``."""
    return f"{approach}/{arch}{'+dueling' if dueling else ''}"


__all__ = [
    "ARCHITECTURES",
    "POOLING",
    "DownsampledQNetwork",
    "build_q_network",
    "network_name",
]
