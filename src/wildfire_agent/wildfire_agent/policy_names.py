"""What a policy name means: the one place that parses ``--policy`` and the ``policy`` parameter.

* ``rh`` — our receding-horizon baseline (other aircraft predicted at constant bank);
* ``rh-paper`` — the paper's uncoordinated receding horizon (each aircraft plans alone), the
  same planner settings otherwise (``receding_horizon.py`` documents the difference);
* ``random`` — uniformly random actions;
* ``obs`` / ``belief`` — the shipped Q-networks (``wildfire_learning.controllers`` finds
  their files; an agent node is given the path);
* anything ending in ``.pt`` or naming an existing file — a TorchScript Q-network.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from wildfire_agent.receding_horizon import RecedingHorizonConfig

PLANNER_POLICIES = ("rh", "rh-paper")
"""Receding-horizon baselines."""
BUILTIN_POLICIES = (*PLANNER_POLICIES, "random")
"""Policies with no file (and so no model card)."""
SHIPPED_POLICIES = ("obs", "belief")
"""Names of the shipped Q-network files."""
EXPECTED_POLICIES = "rh, rh-paper, random, obs, belief or a TorchScript .pt file"
"""How an error message names what a policy may be."""


def planner_config(
    policy: str, base: RecedingHorizonConfig | None = None
) -> RecedingHorizonConfig | None:
    """Planner settings of ``rh`` / ``rh-paper`` (T, tau, restarts from ``base``); else None."""
    if policy not in PLANNER_POLICIES:
        return None
    return replace(base or RecedingHorizonConfig(), model_others=policy == "rh")


def is_policy_file(policy: str) -> bool:
    """True when ``policy`` names a TorchScript file rather than a built-in controller."""
    return policy.endswith(".pt") or Path(policy).exists()


__all__ = [
    "BUILTIN_POLICIES",
    "EXPECTED_POLICIES",
    "PLANNER_POLICIES",
    "SHIPPED_POLICIES",
    "is_policy_file",
    "planner_config",
]
