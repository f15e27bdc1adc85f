"""The incumbents of the clairvoyant bound ``oracle`` (``wildfire_learning.oracle``): the
flights of the shipped policies on the episode the oracle plans, flown in a private
one-episode environment. The best team flight anyone has found is where the oracle's
refinement starts (docs/model.md, Baselines: the clairvoyant bound)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch

from wildfire_agent.policy_names import (
    BUILTIN_POLICIES,
    CAMERA_POLICY,
    CAMERA_RADIO_POLICY,
    OBS_CAMERA_POLICY,
    SHIPPED_POLICIES,
)
from wildfire_world.env import EnvConfig, VecPolicy, WildfireVecEnv

INCUMBENT_POLICIES = tuple(
    str(name)
    for name in (*BUILTIN_POLICIES, *SHIPPED_POLICIES)
    if name not in ("random", CAMERA_POLICY, CAMERA_RADIO_POLICY, OBS_CAMERA_POLICY)
)
"""The shipped policies whose flights are the oracle's incumbents: ``random`` never wins, and
the camera-trained networks belong to another world than the paper's disc the oracle plans."""


def flight_of(policy: VecPolicy, config: EnvConfig, seed: int) -> np.ndarray:
    """The (N, L) actions ``policy`` flies in episode ``seed``, in a private one-episode
    environment (torch on one thread meanwhile: a Q-network flies several times faster so
    on a shared machine)."""
    env = WildfireVecEnv(replace(config, observation=policy.observation), 1)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        observations = env.reset(np.asarray([seed]))
        policy.reset(env)
        flown = []
        while not env.done[0]:
            actions = policy.act(env, observations)
            flown.append(actions[0].copy())
            observations = env.step(actions).observations
    finally:
        torch.set_num_threads(threads)
    return np.ascontiguousarray(np.stack(flown, axis=1), np.int64)


__all__ = ["INCUMBENT_POLICIES", "flight_of"]
