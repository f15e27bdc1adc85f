"""The JSON card of an exported policy: what was trained, how long, and how well it scored.

``export.py`` writes it inside the TorchScript file and as a sidecar; ``wildfire eval
--card`` adds test evaluations to it later.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

from wildfire_agent.approaches import image_shape
from wildfire_learning.export import sidecar_path
from wildfire_learning.train_config import RunOptions, TrainConfig, TrainState

EVALUATION_PROTOCOL = "team belief reward (docs/model.md, Evaluation), greedy network, batched"
"""How a card's ``evaluation`` was scored (training's validation, or an ensemble's)."""


def policy_sha256(path: Path) -> str:
    """The SHA-256 of a policy file: how an ensemble's card and a stored evaluation name the
    exact weights they were made from."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def init_summary(path: Path) -> dict[str, Any]:
    """What a fine-tuned run started from: the policy file and its own training figures."""
    card: dict[str, Any] = {}
    # No readable sidecar: the path alone still says where the weights came from.
    with contextlib.suppress(OSError, ValueError):
        card = json.loads(sidecar_path(path).read_text())
    evaluation = card.get("evaluation", {})
    return {
        "path": str(path),
        "iterations": card.get("iterations"),
        "samples": card.get("samples"),
        "wall_time_s": card.get("wall_time_s"),
        "config": card.get("config"),
        "score_mean": evaluation.get("score_mean"),
    }


def policy_card(
    config: TrainConfig, state: TrainState, options: RunOptions, bag_transitions: int
) -> dict[str, Any]:
    """The card of the network as trained so far (after at least one evaluation)."""
    final = state.curve[-1]
    seeds = config.eval_seeds()
    return {
        "approach": config.approach,
        "arch": config.arch,
        "format": "pairwise Q-network: forward(images (B,C,H,W), states (B,K,5)) -> (B,K,2)",
        "image_shape": list(image_shape(config.approach, config.sensor)),
        "actions": ["bank -5 deg", "bank +5 deg"],
        "config": asdict(config),
        # The ground it trained on, the fuel raster by its hash (a path alone could change).
        "world": config.env_config().ground.summary(),
        "iterations": state.iterations,
        "samples": state.samples,
        "wall_time_s": round(state.wall_time_s, 1),
        "initialised_from": state.initialised_from,
        "trained_from_bags": [str(p) for p in options.bag_dirs],
        "bag_transitions": bag_transitions,
        "offline": options.offline,
        "device": options.device,
        "evaluation": {
            "protocol": EVALUATION_PROTOCOL,
            "iteration": int(final["iteration"]),
            "shapes": list(config.eval_shapes),
            "seeds": [seeds[0], seeds[-1]],
            "episodes": int(final["episodes"]),
            "score_mean": final["score_mean"],
            "score_sem": final["score_sem"],
            "belief_iou_mean": final["belief_iou_mean"],
            "receding_horizon_score": options.baseline_score,
        },
        "learning_curve": [
            {
                "iteration": r["iteration"],
                "score_mean": r["score_mean"],
                "score_sem": r["score_sem"],
            }
            for r in state.curve
        ],
    }


__all__ = ["EVALUATION_PROTOCOL", "init_summary", "policy_card", "policy_sha256"]
