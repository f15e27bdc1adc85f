"""Export a trained Q-network as a TorchScript policy file with its JSON card.

The file is ``torch.jit.script`` of the module (loadable by ``torch.jit.load`` with no project
import) carrying the card as the extra file ``wildfire_policy.json`` (what
:class:`wildfire_agent.policies.TorchScriptPolicy` reads), and the same card is written as a
sidecar ``<name>.json`` next to it for humans and tools that do not open TorchScript.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import torch
from torch import nn

from wildfire_agent.approaches import APPROACHES
from wildfire_agent.policies import save_policy_card
from wildfire_learning.errors import LearningError


def sidecar_path(policy_path: str | Path) -> Path:
    """``models/obs_policy.pt`` -> ``models/obs_policy.json``."""
    return Path(policy_path).with_suffix(".json")


def export_policy(model: nn.Module, path: str | Path, card: dict[str, Any]) -> Path:
    """Script ``model`` (a CPU copy in eval mode) and write it with ``card``; return the path."""
    if card.get("approach") not in APPROACHES:
        raise LearningError(
            f"policy card: approach must be obs or belief, got {card.get('approach')!r}"
        )
    path = Path(path)
    if not path.parent.is_dir():
        raise LearningError(f"--out {path}: directory {path.parent} does not exist")
    # Deployment feeds single NCHW images: drop a channels-last training layout.
    # torch's stubs omit the memory_format keyword that Module.to accepts.
    module = copy.deepcopy(model).to("cpu", memory_format=torch.contiguous_format)  # type: ignore[call-overload]
    module = module.eval()
    _save_with_card(torch.jit.script(module), path, card)
    return path


def _save_with_card(scripted: torch.jit.ScriptModule, path: Path, card: dict[str, Any]) -> None:
    """Write a scripted policy carrying ``card``, and the same card as its sidecar."""
    # Write next to the target then rename: an interrupted export never leaves half a file.
    partial = path.with_name(path.name + ".partial")
    torch.jit.save(scripted, str(partial), _extra_files=save_policy_card(card))
    partial.replace(path)
    sidecar_path(path).write_text(json.dumps(card, indent=2, sort_keys=True) + "\n")


def record_evaluation(policy_path: str | Path, scenario: str, result: dict[str, Any]) -> Path:
    """Add an evaluation to a policy's card (``test_evaluations[scenario]``), in both copies.

    The card inside the TorchScript file and its sidecar stay identical: the module is loaded
    and saved again with the updated card. Returns the sidecar path.
    """
    from wildfire_agent.policies import TorchScriptPolicy

    policy = TorchScriptPolicy(policy_path)  # raises a one-line error for a bad file
    card = dict(policy.card)
    card.setdefault("test_evaluations", {})[scenario] = result
    _save_with_card(policy.module, Path(policy_path), card)
    return sidecar_path(policy_path)


__all__ = ["export_policy", "record_evaluation", "sidecar_path"]
