"""Q-network architectures to train: the paper's, and a faster one for the belief image.

* ``paper`` — :class:`wildfire_learning.network.QNetwork` on the full image (SPEC 2.5).
* ``fast`` — the same network behind a 2 x 2 average pool of the input image, so the
  100 x 100 belief image is seen at 50 x 50 (one pixel = 20 m; burning becomes the burning
  fraction of the 2 x 2 block, age its mean). Its convolutions cost ~4x less; on this CPU the
  paper's belief network trains at ~1 iteration/s, far from the paper's 24 h budget. The
  pool lives inside the module, so a ``fast`` policy file takes the same 2 x 100 x 100 input
  and the agent nodes need no change. For the 30 x 40 sensor image ``fast`` is not offered:
  the paper's network is already fast there.
"""

from __future__ import annotations

import torch
from torch import nn

from wildfire_learning.errors import LearningError
from wildfire_learning.network import QNetwork

ARCHITECTURES = ("paper", "fast")
IMAGE_SHAPES = {"obs": (1, 30, 40), "belief": (2, 100, 100)}
"""Network input image (C, H, W) of each approach."""
STATE_SHAPE_K2 = (1, 5)
"""Pairwise-state shape of one ownship with one other aircraft (training uses 2 aircraft)."""


class DownsampledQNetwork(nn.Module):
    """:class:`QNetwork` on a 2 x 2 average-pooled image (same forward signature)."""

    def __init__(self, image_shape: tuple[int, int, int]) -> None:
        super().__init__()
        channels, height, width = image_shape
        self.pool = nn.AvgPool2d(2)
        self.q = QNetwork((channels, height // 2, width // 2))

    def forward(self, images: torch.Tensor, states: torch.Tensor) -> torch.Tensor:
        return self.q(self.pool(images), states)


def build_q_network(approach: str, arch: str = "paper") -> nn.Module:
    """A freshly initialised Q-network for ``approach`` (obs/belief) and ``arch``."""
    if approach not in IMAGE_SHAPES:
        raise LearningError(f"approach: expected obs or belief, got {approach!r}")
    if arch not in ARCHITECTURES:
        raise LearningError(f"arch: expected one of {ARCHITECTURES}, got {arch!r}")
    shape = IMAGE_SHAPES[approach]
    if arch == "fast":
        if approach != "belief":
            raise LearningError("arch fast: only for the belief approach (obs is already fast)")
        return DownsampledQNetwork(shape)
    return QNetwork(shape)


__all__ = ["ARCHITECTURES", "IMAGE_SHAPES", "DownsampledQNetwork", "build_q_network"]
