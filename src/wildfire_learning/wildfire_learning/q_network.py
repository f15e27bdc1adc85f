"""The paper's Q-network, shared by both approaches (docs/model.md, Q-network).

Image branch: conv 64@3x3 -> maxpool 2 -> conv 64@3x3 -> maxpool 2 -> conv 64@3x3 -> maxpool 2
-> dense 500 -> dense 100. State branch: 5 dense layers of 100. The two 100-wide outputs are
concatenated (200) -> dense 200 -> dense 200 -> 2 Q-values. ReLU everywhere but the output.
Convolutions are padded ("same"), so a 30 x 40 sensor image pools to 3 x 5 and a 100 x 100
belief image to 12 x 12.

``forward(images (B, C, H, W), states (B, K, 5)) -> (B, K, 2)``: the image branch runs once
per ownship and its features are paired with each of its K pairwise states.

``dueling=True`` (an option beyond the paper, Wang et al. 2016) ends the head in two streams
instead of the last dense layer: a state value V and the two actions' advantages A, combined
as ``Q = V + A - mean(A)``. Both actions' Bellman errors then move the shared V, which is
most of Q here (the two actions' values differ by ~2 %: one 5 degree bank step rarely
changes much), and the advantage stream only has to learn their small difference.
"""

from __future__ import annotations

import torch
from torch import nn

from wildfire_agent.pairwise import STATE_SIZE


def conv_output_size(height: int, width: int) -> tuple[int, int]:
    """Spatial size after the three 2 x 2 max-pools."""
    for _ in range(3):
        height, width = height // 2, width // 2
    return height, width


class DuelingHead(nn.Module):
    """The last layer of a dueling head: ``Q = V + A - mean(A)`` over the two actions."""

    def __init__(self, width: int, actions: int = 2) -> None:
        super().__init__()
        self.value = nn.Linear(width, 1)
        self.advantage = nn.Linear(width, actions)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        advantage = self.advantage(features)
        # Subtracting the mean pins V to the actions' average value (V alone is not
        # identifiable from Q otherwise).
        return self.value(features) + advantage - advantage.mean(dim=1, keepdim=True)


class QNetwork(nn.Module):
    """Pairwise Q-network of the paper (with a dueling last layer when ``dueling``)."""

    def __init__(
        self,
        image_shape: tuple[int, int, int],
        state_size: int = STATE_SIZE,
        dueling: bool = False,
    ) -> None:
        super().__init__()
        channels, height, width = image_shape
        pooled_h, pooled_w = conv_output_size(height, width)
        self.image_branch = nn.Sequential(
            nn.Conv2d(channels, 64, 3, padding=1),
            nn.ReLU(),
            nn.MaxPool2d(2),
            nn.Conv2d(64, 64, 3, padding=1),
            nn.ReLU(),
            nn.MaxPool2d(2),
            nn.Conv2d(64, 64, 3, padding=1),
            nn.ReLU(),
            nn.MaxPool2d(2),
            nn.Flatten(),
            nn.Linear(64 * pooled_h * pooled_w, 500),
            nn.ReLU(),
            nn.Linear(500, 100),
            nn.ReLU(),
        )
        state_layers: list[nn.Module] = []
        width_in = state_size
        for _ in range(5):
            state_layers += [nn.Linear(width_in, 100), nn.ReLU()]
            width_in = 100
        self.state_branch = nn.Sequential(*state_layers)
        self.head = nn.Sequential(
            nn.Linear(200, 200),
            nn.ReLU(),
            nn.Linear(200, 200),
            nn.ReLU(),
            DuelingHead(200) if dueling else nn.Linear(200, 2),
        )

    def forward(self, images: torch.Tensor, states: torch.Tensor) -> torch.Tensor:
        image_features = self.image_branch(images)  # (B, 100)
        batch, pairs = states.shape[0], states.shape[1]
        state_features = self.state_branch(states.reshape(batch * pairs, states.shape[2]))
        paired_images = image_features.repeat_interleave(pairs, dim=0)
        q = self.head(torch.cat([paired_images, state_features], dim=1))
        return q.reshape(batch, pairs, 2)


__all__ = ["DuelingHead", "QNetwork", "conv_output_size"]
