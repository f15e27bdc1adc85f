"""Policy inference and DQN training speed on this machine (one torch thread).

* ``*_inference_ms``: median time of one decision of one ownship through
  :class:`wildfire_agent.policies.TorchScriptPolicy` (what an agent node runs), for the shipped
  model if present, else a freshly exported network of the same architecture (weights do not
  change the time). Targets: obs <= 5 ms, belief <= 10 ms.
* ``train_iteration_ms_*``: median time of one training iteration alone (``dqn.td_update``:
  a 64-sample mini-batch drawn from a full replay, the target and online forward passes, the
  backward pass and the AdaMax step), the per-iteration cost of each architecture.
* ``train_*``: a short real ``dqn.train`` run per approach/architecture (batched environments,
  prefill, training iterations, one tiny evaluation): samples/s and iterations/s of the
  training phase, environment samples/s of the random-action prefill, and the replay memory
  the paper's 70 000-transition capacity would take.

``device`` (``wildfire bench --device``) holds the networks and mini-batches; the
environments stay on the CPU.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from wildfire_agent.approaches import IMAGE_SHAPES
from wildfire_agent.policies import TorchScriptPolicy
from wildfire_agent.policy_names import MODELS_DIR
from wildfire_learning.architectures import build_q_network
from wildfire_learning.dqn import td_update, train
from wildfire_learning.export import export_policy
from wildfire_learning.replay import ImageCodec, ReplayBuffer
from wildfire_learning.train_config import RunOptions, TrainConfig

PAPER_REPLAY = 70_000
VARIANTS = (
    ("obs", "paper", "obs"),
    ("belief", "paper", "belief"),
    ("belief", "fast", "belief_fast"),
    ("belief", "lite", "belief_lite"),
)
"""(approach, architecture, figure key) of every network timed."""


def _shipped_arch(path: Path) -> str | None:
    """Architecture named by a shipped policy's JSON card (None: no policy or no card)."""
    card = path.with_suffix(".json")
    if not (path.is_file() and card.is_file()):
        return None
    try:
        return str(json.loads(card.read_text()).get("arch"))
    except (OSError, ValueError):
        return None


def _policy_file(approach: str, arch: str, directory: Path) -> tuple[Path, str]:
    shipped = MODELS_DIR / f"{approach}_policy.pt"
    if _shipped_arch(shipped) == arch:
        return shipped, "shipped"
    path = directory / f"{approach}_{arch}.pt"
    export_policy(build_q_network(approach, arch), path, {"approach": approach, "arch": arch})
    return path, "untrained (timing only)"


def inference_ms(path: Path, approach: str, repeats: int, device: str = "cpu") -> float:
    """Median ms of one ownship decision (batch of one image, one pairwise state)."""
    policy = TorchScriptPolicy(path, device=device)
    rng = np.random.default_rng(0)
    image = rng.random((1, *IMAGE_SHAPES[approach])).astype(np.float32)
    state = rng.standard_normal((1, 1, 5)).astype(np.float32)
    for _ in range(5):
        policy.act(image, state)
    times = []
    for _ in range(repeats):
        tic = time.perf_counter()
        policy.act(image, state)
        times.append(time.perf_counter() - tic)
    return float(np.median(times) * 1000.0)


def iteration_ms(approach: str, arch: str, repeats: int, device: str = "cpu") -> float:
    """Median ms of one training iteration on a replay of random frames (weights and image
    contents do not change the time)."""
    config = TrainConfig(approach=approach, arch=arch)
    memory_format = torch.channels_last if config.channels_last else torch.contiguous_format
    # torch's stubs omit the memory_format keyword that Module.to accepts.
    q_network = config.q_network().to(device, memory_format=memory_format)  # type: ignore[call-overload]
    target = config.q_network().to(device, memory_format=memory_format)  # type: ignore[call-overload]
    optimizer = torch.optim.Adamax(q_network.parameters(), lr=config.learning_rate)
    shape = IMAGE_SHAPES[approach]
    replay = ReplayBuffer(1_000, shape, (1, 5), ImageCodec.for_approach(approach))
    rng = np.random.default_rng(0)
    ids = replay.add_frames(
        rng.integers(0, 2, (1_001, *shape)).astype(np.float32),
        rng.standard_normal((1_001, 1, 5)).astype(np.float32),
    )
    replay.add_transitions(ids[:-1], rng.integers(0, 2, 1_000), rng.random(1_000), 0, ids[1:], 20)
    for _ in range(3):
        td_update(q_network, target, optimizer, replay, config, rng)
    times = []
    for _ in range(repeats):
        tic = time.perf_counter()
        td_update(q_network, target, optimizer, replay, config, rng)
        if device.startswith("cuda"):
            torch.cuda.synchronize()  # the step's kernels, not just their launch
        times.append(time.perf_counter() - tic)
    return float(np.median(times) * 1000.0)


def train_speed(
    approach: str,
    arch: str,
    iterations: int,
    directory: Path,
    device: str = "cpu",
    prefill: int = 2_000,
) -> dict[str, float]:
    """Samples/s and iterations/s of a short real training run (after ``prefill`` samples)."""
    config = TrainConfig(
        approach=approach,
        arch=arch,
        iterations=iterations,
        num_envs=16,
        buffer_size=5_000,
        learning_starts=prefill,
        eval_every=0,
        checkpoint_every=0,
        eval_episodes=1,
        episode_seconds=2.0,
    )
    run_dir = directory / f"train_{approach}_{arch}"
    result = train(config, RunOptions(run_dir=run_dir, out=run_dir / "policy.pt", device=device))
    frame = ReplayBuffer(1, IMAGE_SHAPES[approach], (1, 5), ImageCodec.for_approach(approach))
    per_frame = (frame.images.nbytes + frame.states.nbytes) / frame.frame_capacity
    return {
        "samples_per_s": result.samples_per_s,
        "iterations_per_s": result.iterations_per_s,
        "env_samples_per_s": result.prefill_samples_per_s,
        "replay_mb_at_70k": (PAPER_REPLAY * 1.05 * per_frame + PAPER_REPLAY * 32) / 2**20,
    }


def bench_inference(
    quick: bool = False, device: str = "cpu", smoke: bool = False
) -> dict[str, Any]:
    """Inference ms per decision and training speed, both approaches, one torch thread
    (``smoke``: each measured once, at its smallest size)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    figures: dict[str, Any] = {}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            directory = Path(tmp)
            repeats = 3 if smoke else 50 if quick else 300
            for approach, arch, key in VARIANTS:
                path, source = _policy_file(approach, arch, directory)
                figures[f"{key}_inference_ms"] = inference_ms(path, approach, repeats, device)
                figures[f"{key}_model"] = source
            for approach, arch, key in VARIANTS:
                figures[f"train_iteration_ms_{key}"] = iteration_ms(
                    approach, arch, 1 if smoke else 5 if quick else 30, device
                )
            budgets = {"obs": 20, "belief": 3, "belief_fast": 8, "belief_lite": 20}
            if quick or smoke:
                budgets = {"obs": 6, "belief": 1, "belief_fast": 2, "belief_lite": 6}
            if smoke:
                budgets = dict.fromkeys(budgets, 1)
            prefill = 200 if smoke else 2_000
            for approach, arch, key in VARIANTS:
                speed = train_speed(approach, arch, budgets[key], directory, device, prefill)
                figures[f"train_samples_per_s_{key}"] = speed["samples_per_s"]
                figures[f"train_iterations_per_s_{key}"] = speed["iterations_per_s"]
                figures[f"env_samples_per_s_{key}"] = speed["env_samples_per_s"]
                figures[f"replay_mb_at_70k_{key}"] = speed["replay_mb_at_70k"]
    finally:
        torch.set_num_threads(threads)
    return figures


__all__ = ["bench_inference", "inference_ms", "iteration_ms", "train_speed"]
