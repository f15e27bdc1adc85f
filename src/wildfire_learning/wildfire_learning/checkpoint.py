"""What a training run keeps to be resumed: checkpoint and replay.

``checkpoint.pt`` holds everything a resumed run needs besides the replay — the config, the
counters (:class:`TrainState`), both networks, the optimiser and both random states — and
``replay.npz`` the replay. Each is written to a temporary file and renamed, so an interrupted
save never leaves half a file. (The learning curve beside them is ``plots.write_curve``'s.)

Old checkpoints keep training the way they started: a config saved before a hyperparameter
existed reads it as the value that reproduces the old behaviour (:data:`PRE_EXTENSION_VALUES`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import nn

from wildfire_learning.errors import LearningError
from wildfire_learning.experience import replay_shapes
from wildfire_learning.replay import ReplayBuffer

if TYPE_CHECKING:  # dqn imports this module
    from wildfire_learning.dqn import TrainConfig

CHECKPOINT_FILE = "checkpoint.pt"
REPLAY_FILE = "replay.npz"
CHECKPOINT_FORMAT = "wildfire-dqn-checkpoint/1"
PRE_EXTENSION_VALUES: dict[str, Any] = {
    "n_step": 1,
    "reward_scale": 1.0,
    "explore_hold": 1,
    "double_q": False,
}
"""Values of fields added after the first runs, for configs saved before them: a resumed run
keeps training the way it started (one-step, unscaled, plain epsilon-greedy, single Q)."""


@dataclass
class TrainState:
    """Counters of a run (saved in checkpoints)."""

    samples: int = 0
    """Aircraft decisions taken in training episodes."""
    iterations: int = 0
    """Gradient steps done."""
    episodes: int = 0
    """Training episodes started (the next training seed)."""
    wall_time_s: float = 0.0
    """Wall time spent in this run over all sessions."""
    train_wall_s: float = 0.0
    """Wall time of the training phase (after the prefill)."""
    train_samples: int = 0
    """Samples taken during the training phase."""
    last_loss: float = float("nan")
    curve: list[dict[str, float]] = field(default_factory=list)
    """Learning-curve rows (``plots.CURVE_FIELDS``)."""
    initialised_from: dict[str, Any] | None = None
    """The exported policy a fine-tuning run started from (kept across ``--resume``)."""

    @property
    def last_score(self) -> float | None:
        """Score of the latest evaluation, if any."""
        return self.curve[-1]["score_mean"] if self.curve else None


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


def upgrade_saved_config(saved: dict[str, Any]) -> dict[str, Any]:
    """A checkpoint's config with the fields it predates set to their original behaviour."""
    return {k: v for k, v in PRE_EXTENSION_VALUES.items() if k not in saved} | saved


def resume(
    run_dir: Path,
    config: TrainConfig,
    q_network: nn.Module,
    target_network: nn.Module,
    optimizer: torch.optim.Optimizer,
    rng: np.random.Generator,
) -> tuple[TrainState, ReplayBuffer]:
    """Load the checkpoint of ``run_dir`` into the networks, optimiser and random states;
    return its counters and replay. The network (and so the replay's shapes) must be the one
    the checkpoint trained."""
    payload = load_checkpoint(run_dir)
    # Fields a config predates read as their defaults (the values they were run with).
    saved = {f.name: f.default for f in fields(config)} | payload["config"]
    trained = (saved["approach"], saved["arch"], saved["n_aircraft"])
    if trained != (config.approach, config.arch, config.n_aircraft):
        raise LearningError(
            f"checkpoint {run_dir / CHECKPOINT_FILE}: incompatible (trained {trained[0]}/"
            f"{trained[1]} with {trained[2]} aircraft, asked {config.approach}/{config.arch} "
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


def load_policy_weights(model: nn.Module, path: Path, approach: str, arch: str) -> None:
    """Copy the weights of an exported policy file into ``model`` (same approach and arch)."""
    from wildfire_agent.errors import AgentConfigError
    from wildfire_agent.policies import TorchScriptPolicy

    try:
        policy = TorchScriptPolicy(path)
    except AgentConfigError as error:
        raise LearningError(f"--init-from {error}") from None
    trained = (policy.card.get("approach"), policy.card.get("arch", "paper"))
    if trained != (approach, arch):
        raise LearningError(
            f"--init-from {path}: a {trained[0]}/{trained[1]} policy, "
            f"this run trains {approach}/{arch}"
        )
    model.load_state_dict(policy.module.state_dict())


__all__ = [
    "CHECKPOINT_FILE",
    "CHECKPOINT_FORMAT",
    "PRE_EXTENSION_VALUES",
    "REPLAY_FILE",
    "TrainState",
    "load_checkpoint",
    "load_policy_weights",
    "resume",
    "save_checkpoint",
    "upgrade_saved_config",
]
