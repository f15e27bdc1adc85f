"""What a policy name means, and the one factory that builds it: ``--policy``, the agent's
``policy`` parameter and every policy of the training package go through
:func:`make_policy`.

* ``rh`` — our receding-horizon baseline (other aircraft predicted at constant bank);
* ``rh-paper`` — the paper's uncoordinated receding horizon (each aircraft plans alone), the
  same planner settings otherwise (``receding_horizon.py`` documents the difference);
* ``rh-belief`` — ``rh`` planning on the team's believed map instead of the truth (the fair
  baseline of the learned policies);
* ``random`` — uniformly random actions;
* ``obs`` / ``belief`` — the shipped Q-networks (``models/<name>_policy.pt``);
* ``belief-radio`` — the shipped belief network trained under limited radio links
  (``--comm range=300,loss=0.2``: each aircraft on its own replica;
  ``models/belief_radio_policy.pt``);
* ``belief-camera`` — the shipped belief network trained under camera sensing
  (``--sensor camera --pixel-error 0.1``: the filtered belief; ``models/belief_camera_policy.pt``);
* ``belief-camera-radio`` — ``belief-camera`` fine-tuned under camera sensing and limited
  radio links (``range=300,loss=0.2``: each aircraft on its own filtered replica;
  ``models/belief_camera_radio_policy.pt``);
* ``obs-camera`` — the shipped observation network of that world: it sees its own four noisy
  camera images (``camera_view``; ``models/obs_camera_policy.pt``);
* anything ending in ``.pt`` or naming an existing file — a TorchScript Q-network;
* ``MODULE:ATTR`` — a vector policy from outside the project (``user_policy`` documents the
  protocol and resolves the name).

A policy flies a set of aircraft: one for an agent node's aircraft policy, every aircraft of every
episode for an environment policy. Either way aircraft ``k`` of episode ``s`` draws its
random numbers (random actions, planner restarts) from ``generator(s, AIRCRAFT, k)``, so an
aircraft flies the same alone, in a batch of episodes, or as its own agent node.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import torch

from wildfire_agent.approaches import APPROACHES
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.policies import RandomPolicy, TorchScriptPolicy
from wildfire_agent.receding_horizon import (
    RecedingHorizonConfig,
    RecedingHorizonPolicy,
    replan_phases,
)
from wildfire_agent.rewards import ObservationRewardWeights
from wildfire_agent.user_policy import (
    USER_POLICY_FORM,
    VecPolicy,
    is_user_policy,
    load_user_policy,
    module_file,
)
from wildfire_sim.seeding import Stream, generator

BELIEF_PLANNER = "rh-belief"
"""The receding horizon on the believed map."""
PLANNER_POLICIES = ("rh", "rh-paper", BELIEF_PLANNER)
"""Receding-horizon baselines."""
BUILTIN_POLICIES = (*PLANNER_POLICIES, "random")
"""Policies with no file (and so no model card)."""
RADIO_POLICY = "belief-radio"
"""The belief network trained under limited radio links."""
CAMERA_POLICY = "belief-camera"
"""The belief network trained under camera sensing."""
CAMERA_RADIO_POLICY = "belief-camera-radio"
"""The camera belief network fine-tuned under limited radio links."""
OBS_CAMERA_POLICY = "obs-camera"
"""The observation network of the camera world (it sees its camera images)."""
SHIPPED_POLICIES = (
    *APPROACHES,
    RADIO_POLICY,
    CAMERA_POLICY,
    CAMERA_RADIO_POLICY,
    OBS_CAMERA_POLICY,
)
"""Names of the shipped Q-networks (one per approach, the belief network trained under
limited radio links, both approaches trained under camera sensing, and the camera belief
network under both)."""
EXPECTED_POLICIES = (
    "rh, rh-paper, rh-belief, random, obs, belief, belief-radio, belief-camera, "
    "belief-camera-radio, obs-camera, "
    f"a TorchScript .pt file or {USER_POLICY_FORM} (a vector policy of your own)"
)
"""How an error message names what a policy may be."""
ORACLE_POLICY = "oracle"
"""The clairvoyant bound (``wildfire_learning.oracle``): it reads the fire's future, so
``wildfire eval`` and ``wildfire report`` fly it and nothing else does (:func:`make_policy`,
and so an agent node, refuses the name as unknown)."""
EVAL_ONLY_POLICIES = (ORACLE_POLICY,)
"""Policies with no file that only evaluation flies."""
FILELESS_POLICIES = (*BUILTIN_POLICIES, *EVAL_ONLY_POLICIES)
"""Policy names with no policy file (and so no model card) behind them."""
MODELS_DIR = Path(__file__).resolve().parents[3] / "models"
"""Shipped policies (``obs_policy.pt``, ``belief_policy.pt``, ``belief_radio_policy.pt``,
``belief_camera_policy.pt``, ``belief_camera_radio_policy.pt``, ``obs_camera_policy.pt``)
in the repository."""

Policy = RecedingHorizonPolicy | RandomPolicy | TorchScriptPolicy
"""A policy flying a set of aircraft (what :meth:`PolicyFactory.build` returns)."""


def planner_config(
    policy: str, base: RecedingHorizonConfig | None = None
) -> RecedingHorizonConfig | None:
    """Planner settings of ``rh`` / ``rh-paper`` / ``rh-belief`` (T, tau, restarts from
    ``base``); else None."""
    if policy not in PLANNER_POLICIES:
        return None
    return replace(
        base or RecedingHorizonConfig(),
        model_others=policy != "rh-paper",
        believed_map=policy == BELIEF_PLANNER,
    )


def is_policy_file(policy: str) -> bool:
    """True when ``policy`` names a TorchScript file rather than a built-in policy."""
    return policy.endswith(".pt") or Path(policy).exists()


def has_network_file(name: str) -> bool:
    """True when ``name`` is a Q-network (a shipped name or a ``.pt`` file): it has a file,
    a model card and bytes a remote worker is sent."""
    return is_policy_file(name) or (name not in FILELESS_POLICIES and not is_user_policy(name))


def policy_source(name: str) -> Path | None:
    """The file a policy's results depend on beyond the project's code: a Q-network's, or a
    policy of your own's module; None for the built-in policies."""
    if has_network_file(name):
        return resolve_policy_path(name)
    if is_user_policy(name):
        return module_file(name)
    return None


def resolve_policy_path(name: str) -> Path:
    """Path of a Q-network given as a shipped name (``belief-radio`` is
    ``belief_radio_policy.pt``) or a file path."""
    if name in SHIPPED_POLICIES:
        path = MODELS_DIR / f"{name.replace('-', '_')}_policy.pt"
        if not path.is_file():
            raise AgentConfigError(
                f"policy {name!r}: the shipped model {path} is missing "
                "(train one with `wildfire train`, or use rh, rh-paper, random or a .pt file)"
            )
        return path
    return Path(name)


@dataclass(frozen=True)
class PolicyFactory:
    """A policy name made concrete: planner settings, a Q-network loaded once, or neither
    (uniformly random actions)."""

    planner: RecedingHorizonConfig | None = None
    """Planner settings of ``rh`` / ``rh-paper``."""
    network: TorchScriptPolicy | None = None
    """The Q-network of ``obs``, ``belief`` or a file."""
    user: VecPolicy | None = None
    """A vector policy of your own (``MODULE:ATTR``), built once."""

    @property
    def observation(self) -> str:
        """What the policy looks at: ``obs``, ``belief`` or ``none`` (poses and truth only)."""
        if self.user is not None:
            return str(self.user.observation)
        return "none" if self.network is None else self.network.approach

    def build(
        self,
        seeds: Sequence[int] | np.ndarray,
        aircraft: Sequence[int] | np.ndarray,
        n_aircraft: int,
        weights: ObservationRewardWeights | None = None,
    ) -> Policy:
        """The policy flying ``aircraft`` (team indices, of ``n_aircraft``) of each episode of
        ``seeds``, environment-major; ``weights`` are the planner's reward weights. A policy
        of your own flies itself (:attr:`user`)."""
        if self.user is not None:
            raise ValueError("a vector policy of your own is flown as it is, not built")
        if self.network is not None:
            return self.network  # greedy: no randomness to seed
        aircraft = np.asarray(aircraft, dtype=np.int64)
        generators = [
            generator(int(seed), Stream.AIRCRAFT, int(k)) for seed in seeds for k in aircraft
        ]
        if self.planner is None:
            return RandomPolicy(generators)
        # Aircraft re-plan at staggered decisions, whichever set of them a policy flies.
        phases = replan_phases(aircraft, n_aircraft, self.planner.replan_every)
        return RecedingHorizonPolicy(generators, self.planner, weights, np.tile(phases, len(seeds)))


def make_policy(
    name: str,
    rh_config: RecedingHorizonConfig | None = None,
    device: str | torch.device = "cpu",
) -> PolicyFactory:
    """The policy called ``name`` (see the module docstring); ``rh_config`` sets T, tau and
    restarts of the planners, ``device`` where a Q-network runs. Raises
    :class:`AgentConfigError` for an unknown name or a bad file."""
    planner = planner_config(name, rh_config)
    if planner is not None:
        return PolicyFactory(planner=planner)
    if name == "random":
        return PolicyFactory()
    if name in SHIPPED_POLICIES or is_policy_file(name):
        return PolicyFactory(network=TorchScriptPolicy(resolve_policy_path(name), device=device))
    if is_user_policy(name):
        return PolicyFactory(user=load_user_policy(name))
    raise AgentConfigError(f"unknown policy {name!r}: expected {EXPECTED_POLICIES}")


__all__ = [
    "BELIEF_PLANNER",
    "BUILTIN_POLICIES",
    "CAMERA_POLICY",
    "EVAL_ONLY_POLICIES",
    "EXPECTED_POLICIES",
    "FILELESS_POLICIES",
    "MODELS_DIR",
    "OBS_CAMERA_POLICY",
    "ORACLE_POLICY",
    "PLANNER_POLICIES",
    "RADIO_POLICY",
    "SHIPPED_POLICIES",
    "Policy",
    "PolicyFactory",
    "has_network_file",
    "is_policy_file",
    "is_user_policy",
    "make_policy",
    "planner_config",
    "policy_source",
    "resolve_policy_path",
]
