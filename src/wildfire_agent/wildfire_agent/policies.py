"""Policies that choose bank actions: a TorchScript Q-network, or random.

(The receding-horizon baseline lives in ``receding_horizon.py``.)

A Q-network policy file is a TorchScript module ``forward(images, states) -> q`` taking
``images`` (B, C, H, W) float32 (one per ownship) and normalised pairwise states (B, K, 5)
float32 (one per other aircraft) and returning pairwise Q-values (B, K, 2) for the actions
(-5 deg, +5 deg); the image branch runs once per ownship, however many aircraft it pairs
with. It carries a JSON card as the TorchScript extra file ``wildfire_policy.json`` with at
least ``{"approach": "obs" | "belief"}``. With several other aircraft the ownship sums its
pairwise Q-values: ``a = argmax_a sum_j Q(s_j, a)`` (docs/model.md, Q-network).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import torch

from wildfire_agent.approaches import APPROACHES, image_shape
from wildfire_agent.errors import AgentConfigError

POLICY_CARD_FILE = "wildfire_policy.json"
"""Name of the JSON card inside a TorchScript policy file."""


class RandomPolicy:
    """Uniformly random +/-5 degree actions, one generator per aircraft."""

    def __init__(self, generators: list[np.random.Generator]) -> None:
        self.generators = generators

    def act(self) -> np.ndarray:
        """One action per aircraft, (P,) int64."""
        return np.array([int(rng.integers(0, 2)) for rng in self.generators], dtype=np.int64)


class TorchScriptPolicy:
    """Greedy policy of a TorchScript Q-network file, run on ``device`` (the CPU by default:
    agent nodes and evaluation flying what they fly)."""

    def __init__(
        self, path: str | Path, threads: int | None = None, device: str | torch.device = "cpu"
    ) -> None:
        import torch  # here, not at the top: rh and random agents never load torch

        path = Path(path)
        if not path.is_file():
            raise AgentConfigError(f"policy file {path}: no such file (expected a TorchScript .pt)")
        extra_files = {POLICY_CARD_FILE: ""}
        try:
            self.module = torch.jit.load(str(path), map_location=device, _extra_files=extra_files)
        except (RuntimeError, ValueError) as error:
            reason = str(error).strip().splitlines()[0].split(". ")[0] if str(error).strip() else ""
            raise AgentConfigError(
                f"policy file {path}: not a TorchScript module ({reason or 'unreadable'})"
            ) from None
        try:
            self.card: dict[str, Any] = json.loads(extra_files[POLICY_CARD_FILE] or "null") or {}
        except json.JSONDecodeError:
            self.card = {}
        approach = self.card.get("approach")
        if approach not in APPROACHES:
            raise AgentConfigError(
                f"policy file {path}: missing or bad '{POLICY_CARD_FILE}' card "
                f"(expected approach 'obs' or 'belief', got {approach!r})"
            )
        self.path = path
        self.device = torch.device(device)
        self.approach: str = approach
        self.module.eval()
        if threads is not None:
            torch.set_num_threads(threads)

    def check_sensor(self, sensor: str) -> None:
        """Refuse (one line) a world whose images the network does not take: the observation
        network of the disc world and that of the camera world see different images."""
        shape = self.card.get("image_shape")
        expected = image_shape(self.approach, sensor)
        if shape is not None and tuple(shape) != expected:
            raise AgentConfigError(
                f"policy file {self.path}: its network takes {self.approach} images "
                f"{tuple(shape)}, but under --sensor {sensor} they are {expected} (fly it in "
                "the world it was trained in)"
            )

    def q_values(self, images: np.ndarray, pair_states: np.ndarray) -> np.ndarray:
        """Summed pairwise Q-values (B, 2) from images (B, C, H, W) and states (B, K, 5)."""
        q = summed_q_values(self.module, images, pair_states, device=self.device)
        return q.cpu().numpy().astype(np.float64)

    def act(self, images: np.ndarray, pair_states: np.ndarray) -> np.ndarray:
        """Greedy actions (B,) int64."""
        return greedy_actions(self.module, images, pair_states, device=self.device)


def summed_q_values(
    module: torch.nn.Module,
    images: np.ndarray,
    pair_states: np.ndarray,
    channels_last: bool = False,
    device: torch.device | None = None,
) -> torch.Tensor:
    """``sum_j Q(s_j, a)``, (B, 2) on the module's device, from images (B, C, H, W) and
    pairwise states (B, K, 5): the one place a Q-network is queried for actions."""
    import torch

    if device is None:
        device = next(module.parameters()).device
    image_tensor = torch.from_numpy(np.ascontiguousarray(images, dtype=np.float32)).to(device)
    if channels_last:  # a module trained in channels-last runs faster fed that way
        image_tensor = image_tensor.contiguous(memory_format=torch.channels_last)
    state_tensor = torch.from_numpy(np.ascontiguousarray(pair_states, dtype=np.float32))
    with torch.inference_mode():
        q: torch.Tensor = module(image_tensor, state_tensor.to(device))
    return q.sum(dim=1)


def greedy_actions(
    module: torch.nn.Module,
    images: np.ndarray,
    pair_states: np.ndarray,
    channels_last: bool = False,
    device: torch.device | None = None,
) -> np.ndarray:
    """``argmax_a sum_j Q(s_j, a)``, (B,) int64 (on a tie the first action, -5 degrees)."""
    return greedy_actions_and_values(module, images, pair_states, channels_last, device)[0]


def greedy_actions_and_values(
    module: torch.nn.Module,
    images: np.ndarray,
    pair_states: np.ndarray,
    channels_last: bool = False,
    device: torch.device | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`greedy_actions` (B,) and the value ``max_a sum_j Q(s_j, a)`` (B,) float32 the
    network gives each of them."""
    q = summed_q_values(module, images, pair_states, channels_last, device)
    actions = q.argmax(dim=1).cpu().numpy().astype(np.int64)
    return actions, q.amax(dim=1).detach().cpu().numpy()


def save_policy_card(extra: dict[str, Any]) -> dict[str, str]:
    """``_extra_files`` argument for ``torch.jit.save`` carrying a policy card."""
    return {POLICY_CARD_FILE: json.dumps(extra, indent=2, sort_keys=True)}


__all__ = [
    "APPROACHES",
    "POLICY_CARD_FILE",
    "RandomPolicy",
    "TorchScriptPolicy",
    "greedy_actions",
    "greedy_actions_and_values",
    "save_policy_card",
    "summed_q_values",
]
