"""What a training run keeps to be resumed: checkpoint and replay.

``checkpoint.pt`` holds everything a resumed run needs besides the replay — the config, the
counters (:class:`TrainState`), both networks, the optimiser and both random states — and
``replay.npz`` the replay. Each is written to a temporary file and renamed, so an interrupted
save never leaves half a file. (The learning curve beside them is ``plots.write_curve``'s.)

The config a resumed run trains with is ``train_config.resolve_config``'s merge of the saved
one and the values given (old checkpoints keep training the way they started).
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from wildfire_learning.architectures import network_name
from wildfire_learning.errors import LearningError
from wildfire_learning.replay import ReplayBuffer
from wildfire_learning.train_config import TrainConfig, TrainState, replay_shapes, resolve_config

CHECKPOINT_FILE = "checkpoint.pt"
REPLAY_FILE = "replay.npz"
CHECKPOINT_FORMAT = "wildfire-dqn-checkpoint/1"


def save_checkpoint(
    run_dir: Path,
    config: TrainConfig,
    state: TrainState,
    q_network: nn.Module,
    target_network: nn.Module,
    optimizer: torch.optim.Optimizer,
    replay: ReplayBuffer,
    rng: np.random.Generator,
) -> None:
    """Write everything a resumed run needs (atomically: temp files, then rename)."""
    payload = {
        "format": CHECKPOINT_FORMAT,
        "config": asdict(config),
        "state": asdict(state),
        "q_network": q_network.state_dict(),
        "target_network": target_network.state_dict(),
        "optimizer": optimizer.state_dict(),
        "numpy_rng": rng.bit_generator.state,
        "torch_rng": torch.get_rng_state(),
    }
    replay_tmp = run_dir / (REPLAY_FILE + ".partial.npz")
    replay.save(replay_tmp)
    replay_tmp.replace(run_dir / REPLAY_FILE)
    tmp = run_dir / (CHECKPOINT_FILE + ".partial")
    torch.save(payload, tmp)
    tmp.replace(run_dir / CHECKPOINT_FILE)


def load_checkpoint(run_dir: Path) -> dict[str, Any]:
    """Read a checkpoint, or raise :class:`LearningError` with a one-line reason."""
    path = run_dir / CHECKPOINT_FILE
    if not path.is_file():
        raise LearningError(f"--resume: no checkpoint {path}")
    try:
        payload = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as error:  # any unpickling failure means "not ours"
        raise LearningError(f"checkpoint {path}: unreadable ({type(error).__name__})") from None
    if not isinstance(payload, dict) or payload.get("format") != CHECKPOINT_FORMAT:
        raise LearningError(f"checkpoint {path}: not a wildfire DQN checkpoint")
    return payload


def resume(
    run_dir: Path,
    payload: dict[str, Any],
    config: TrainConfig,
    q_network: nn.Module,
    target_network: nn.Module,
    optimizer: torch.optim.Optimizer,
    rng: np.random.Generator,
) -> tuple[TrainState, ReplayBuffer]:
    """Load ``payload``, the checkpoint of ``run_dir`` (:func:`load_checkpoint`), into the
    networks, optimiser and random states; return its counters and replay. The network (and
    so the replay's shapes) must be the one the checkpoint trained."""
    saved = resolve_config(payload["config"], {})
    trained = (saved.network_name(), saved.n_aircraft)
    if trained != (config.network_name(), config.n_aircraft):
        raise LearningError(
            f"checkpoint {run_dir / CHECKPOINT_FILE}: incompatible (trained {trained[0]} "
            f"with {trained[1]} aircraft, asked {config.network_name()} "
            f"with {config.n_aircraft})"
        )
    try:
        q_network.load_state_dict(payload["q_network"])
        target_network.load_state_dict(payload["target_network"])
        optimizer.load_state_dict(payload["optimizer"])
    except (RuntimeError, KeyError, ValueError) as error:
        raise LearningError(f"checkpoint {run_dir}: incompatible network ({error})") from None
    state = TrainState(**payload["state"])
    rng.bit_generator.state = payload["numpy_rng"]
    torch.set_rng_state(payload["torch_rng"])
    replay = ReplayBuffer.load(run_dir / REPLAY_FILE)
    if (replay.image_shape, replay.state_shape) != replay_shapes(config):
        raise LearningError(f"replay {run_dir / REPLAY_FILE}: shapes do not match the network")
    return state, replay


def load_policy_weights(model: nn.Module, path: Path, config: TrainConfig) -> None:
    """Copy the weights of an exported policy file into ``model``, the network of ``config``
    (same approach, arch and head)."""
    from wildfire_agent.errors import AgentConfigError
    from wildfire_agent.policies import TorchScriptPolicy

    try:
        policy = TorchScriptPolicy(path)
    except AgentConfigError as error:
        raise LearningError(f"--init-from {error}") from None
    if "ensemble" in policy.card:
        members = len(policy.card["ensemble"].get("members", []))
        raise LearningError(
            f"--init-from {path}: an ensemble of {members} networks (start from one of its members)"
        )
    trained = network_name(
        str(policy.card.get("approach")),
        str(policy.card.get("arch", "paper")),
        bool(policy.card.get("config", {}).get("dueling", False)),
    )
    if trained != config.network_name():
        raise LearningError(
            f"--init-from {path}: a {trained} policy, this run trains {config.network_name()}"
        )
    model.load_state_dict(policy.module.state_dict())


__all__ = [
    "CHECKPOINT_FILE",
    "CHECKPOINT_FORMAT",
    "REPLAY_FILE",
    "load_checkpoint",
    "load_policy_weights",
    "resume",
    "save_checkpoint",
]
