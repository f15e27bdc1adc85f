"""An ensemble of Q-networks as one policy file: the mean of its members' Q-values.

Networks trained apart (another seed, or a fine-tune that moved away from where it started)
err apart: each over-values some actions in some states, and not the same ones. The mean of
their Q-values keeps what they agree on and damps what only one believes, so its greedy
action can beat either member's (measured on validation seeds by :func:`validate`;
docs/model.md, Q-network, *Ensembles*). The
file stays a plain TorchScript ``forward(images, states) -> q``: agent nodes, ``wildfire
eval`` and a user's own node load it as they load one network, at the members' cost summed.

:func:`ensemble_policy` writes it from exported policy files, with a card that names every
member (its hash and its own card) and adds up what they cost to train. :func:`validate`
then flies the ensemble and each member on the same validation seeds and writes into the
card what the ensemble gains over each, paired, per fire shape: the figures a choice between
them rests on (test seeds are never used for it).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch
from torch import nn

from wildfire_learning.errors import LearningError
from wildfire_learning.evaluate import EvaluationSummary
from wildfire_learning.export import _save_with_card
from wildfire_learning.model_card import EVALUATION_PROTOCOL, policy_sha256
from wildfire_learning.parallel import EvalJob, evaluate_jobs
from wildfire_learning.summary_stats import standard_error
from wildfire_learning.train_config import EVAL_SEED_BASE
from wildfire_world.env import EnvConfig

MEMBER_CARD_KEYS = (
    "arch",
    "config",
    "iterations",
    "samples",
    "wall_time_s",
    "initialised_from",
    "evaluation",
    "selection",
)
"""What the ensemble's card keeps of each member's card (not its learning curve or tests)."""


class QEnsemble(nn.Module):
    """``forward(images, states)``: the mean of the members' pairwise Q-values (B, K, 2)."""

    def __init__(self, members: list[nn.Module]) -> None:
        super().__init__()
        self.members = nn.ModuleList(members)

    def forward(self, images: torch.Tensor, states: torch.Tensor) -> torch.Tensor:
        total = torch.zeros(0)  # TorchScript wants the variable typed before the loop
        count = 0
        # Summed in member order, then divided once: one fixed float order for every caller.
        for member in self.members:
            q = member(images, states)
            total = q if count == 0 else total + q
            count += 1
        return total / count


def member_labels(paths: Sequence[Path]) -> list[str]:
    """How the card names each member: its file name, or its path where members share a
    name (two runs' ``obs_policy.pt``), so that no member's comparison hides another's."""
    names = [path.name for path in paths]
    return [str(path) if names.count(path.name) > 1 else path.name for path in paths]


def ensemble_card(cards: list[dict[str, Any]], paths: list[Path]) -> dict[str, Any]:
    """The ensemble's card: the first member's card for what a loader reads (approach, image
    shape, format, config, learning curve), ``ensemble`` with every member, and the training
    cost summed over the members (``iterations``, ``samples``, ``wall_time_s``)."""
    first = cards[0]
    members = [
        {"file": label, "sha256": policy_sha256(path)}
        | {key: card[key] for key in MEMBER_CARD_KEYS if key in card}
        for label, path, card in zip(member_labels(paths), paths, cards, strict=True)
    ]
    # Its own evaluation and selection come from validate(), its tests from eval --card.
    dropped = ("test_evaluations", "evaluation", "selection")
    card = {key: value for key, value in first.items() if key not in dropped}
    card["ensemble"] = {
        "rule": "mean of the members' pairwise Q-values, greedy action",
        "members": members,
    }
    for key in ("iterations", "samples", "wall_time_s"):
        card[key] = sum(member.get(key) or 0 for member in members)
    return card


def ensemble_policy(paths: list[Path], out: Path) -> Path:
    """Write the ensemble of the policy files ``paths`` (one approach, one image shape) to
    ``out`` with its card; return ``out``."""
    from wildfire_agent.errors import AgentConfigError
    from wildfire_agent.policies import TorchScriptPolicy

    if len(paths) < 2:
        raise LearningError(f"expected at least 2 member policy files, got {len(paths)}")
    try:
        policies = [TorchScriptPolicy(path) for path in paths]
    except AgentConfigError as error:
        raise LearningError(str(error)) from None
    inputs = [(p.approach, tuple(p.card.get("image_shape") or ())) for p in policies]
    if len(set(inputs)) != 1:
        found = ", ".join(f"{path}: {a} {s}" for path, (a, s) in zip(paths, inputs, strict=True))
        raise LearningError(f"members must take the same inputs, got {found}")
    if any("ensemble" in p.card for p in policies):
        raise LearningError("a member is an ensemble itself (give its members instead)")
    if not out.parent.is_dir():
        raise LearningError(f"--out {out}: directory {out.parent} does not exist")
    module = torch.jit.script(QEnsemble([p.module for p in policies]))
    card = ensemble_card([p.card for p in policies], paths)
    _save_with_card(module, out, card)
    return out


def paired(ours: EvaluationSummary, theirs: EvaluationSummary) -> dict[str, Any]:
    """Our gain over ``theirs`` on the same seeds: mean +- s.e. of the per-seed difference."""
    gain = ours.scores - theirs.scores
    return {
        "score_mean": round(float(theirs.scores.mean()), 2),
        "paired_gain": round(float(gain.mean()), 1),
        "paired_gain_sem": round(standard_error(gain), 1),
        "wins": int((gain > 0).sum()),
        "losses": int((gain < 0).sum()),
    }


def validate(
    out: Path,
    members: Sequence[Path],
    shapes: Sequence[str],
    episodes: int,
    n_aircraft: int = 2,
    workers: int = 1,
    ray_address: str | None = None,
) -> dict[str, Any]:
    """Fly the ensemble ``out`` and each member on validation seeds (``episodes`` from
    ``EVAL_SEED_BASE``) per fire shape; record in its card ``evaluation`` (the first shape)
    and ``selection`` (per shape, its score and its paired gain over each member). Returns
    the selection."""
    from wildfire_agent.policies import TorchScriptPolicy

    seeds = tuple(range(EVAL_SEED_BASE, EVAL_SEED_BASE + episodes))
    policies = [str(out), *map(str, members)]
    jobs = [
        EvalJob(policy, EnvConfig(n_aircraft=n_aircraft, shapes=(shape,)), seeds)
        for shape in shapes
        for policy in policies
    ]
    summaries = evaluate_jobs(jobs, workers, ray_address)
    by_shape: dict[str, Any] = {}
    for i, shape in enumerate(shapes):
        ours, *theirs = summaries[i * len(policies) : (i + 1) * len(policies)]
        by_shape[shape] = {
            "score_mean": round(float(ours.scores.mean()), 2),
            "score_sem": round(standard_error(ours.scores), 1),
            "members": {
                label: paired(ours, summary)
                for label, summary in zip(member_labels(members), theirs, strict=True)
            },
        }
    first = summaries[0].to_json()
    selection = {
        "validation_seeds": [seeds[0], seeds[-1]],
        "n_aircraft": n_aircraft,
        "by_shape": by_shape,
    }
    policy = TorchScriptPolicy(out)
    card = dict(policy.card)
    card["evaluation"] = {
        "protocol": EVALUATION_PROTOCOL,
        "shapes": [shapes[0]],
        "seeds": [seeds[0], seeds[-1]],
        "episodes": episodes,
    } | {key: first[key] for key in ("score_mean", "score_sem", "belief_iou_mean")}
    card["selection"] = selection
    _save_with_card(policy.module, out, card)
    return selection


__all__ = [
    "MEMBER_CARD_KEYS",
    "QEnsemble",
    "ensemble_card",
    "ensemble_policy",
    "member_labels",
    "paired",
    "validate",
]
