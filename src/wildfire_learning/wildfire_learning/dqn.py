"""Deep Q-learning of the pairwise Q-network (SPEC 2.5), in the style of CleanRL's ``dqn.py``.

One explicit loop: batched environments (``num_envs`` episodes of two aircraft stepping
together, actions of every aircraft from one batched forward pass), every aircraft's
transition stored in one replay (the network is shared), the replay prefilled with random
actions, then one training iteration (mini-batch 64, AdaMax, MSE Bellman error against a
target network copied every 1000 iterations) per ``train_frequency`` new samples, epsilon
linear from 1 to 0.1 over ``exploration_samples`` samples. Every ``eval_every`` iterations
the greedy network is scored with the SPEC 2.7 protocol on fixed held-out seeds
(``eval_seed_base`` and up; training episodes use seeds below it), the learning curve is
written (CSV + PNG) and a checkpoint (networks, optimizer, replay, RNG states, counters) is
saved so ``--resume`` continues where the run stopped. At the end the network is exported as
a TorchScript policy with its JSON card.

Decisions beyond the paper (documented here, reported in the card):

* Samples are counted per aircraft decision, prefill included: the scripts' "replay 70 000,
  prefill 35 000, 1 iteration per 10 samples, epsilon 0.1 after 500 000 samples".
* Episodes truncated at the time limit bootstrap from their last observation; only the
  fire reaching the border (a true end) stops the bootstrap.
* Gradients are clipped to norm 10 (a guard against rare large Bellman errors early on).
* Learning rate 2.5e-4 (the paper names AdaMax but no rate).
* n-step targets (``n_step``, default 20 decisions = 2 s; 1 is the paper's one-step DQN): at
  10 Hz a one-step target carries the value of the future back one decision per target copy,
  so the 100-decision horizon of gamma = 0.99 would take ~100 000 iterations to appear.
* Rewards are multiplied by ``reward_scale`` (0.01) in the targets, so Q-values are of
  order 1 rather than 100: AdaMax moves each weight by about the learning rate per step, and
  unscaled targets spend thousands of iterations just reaching their magnitude. The greedy
  policy does not depend on the scale.
* Exploring aircraft hold their random action for 1-20 decisions (epsilon-z-greedy, see
  ``exploration.py``), the prefill included; the fraction of random decisions is still
  epsilon. i.i.d. random ±5° steps at 10 Hz only jitter the bank and never make a turn.
* Double DQN targets (``double_q``): less over-estimation of the action the network already
  prefers (single-Q runs here drifted into full-bank circles, where one action is a no-op).
* Epsilon reaches 0.1 after 200 000 samples (the scripts: 500 000), so most of a
  2-3 hour budget on this CPU is spent refining the greedy policy.
* Episodes abandoned by an interruption are not resumed: a resumed run starts new episodes
  (their transitions up to the checkpoint are in the replay).
* ``RunOptions.device`` (``--device``) holds the networks, the optimiser and the replay
  mini-batches; the environments are numpy on the CPU, and the replay stays in host memory
  (uint8 frames, copied per mini-batch). The device is not a hyperparameter: a run may resume
  on another one (the card records the last). The exported policy is always a CPU module.
"""

from __future__ import annotations

import contextlib
import csv
import json
import resource
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from wildfire_learning.architectures import IMAGE_SHAPES, build_q_network
from wildfire_learning.env import EnvConfig, WildfireVecEnv
from wildfire_learning.errors import LearningError
from wildfire_learning.evaluate import VALIDATION_SEED_BASE, EvaluationSummary, evaluate
from wildfire_learning.exploration import PersistentExploration
from wildfire_learning.export import export_policy
from wildfire_learning.nstep import NStepAccumulator
from wildfire_learning.replay import ImageCodec, ReplayBuffer
from wildfire_sim.episode import EPISODE_DEFAULTS

EVAL_SEED_BASE = VALIDATION_SEED_BASE
"""Evaluation seeds during training start here; training seeds stay below."""
CHECKPOINT_FILE = "checkpoint.pt"
REPLAY_FILE = "replay.npz"
CURVE_CSV = "learning_curve.csv"
CURVE_PNG = "learning_curve.png"
CURVE_FIELDS = (
    "iteration",
    "samples",
    "wall_time_s",
    "epsilon",
    "score_mean",
    "score_sem",
    "belief_iou_mean",
    "episodes",
)
POSITIVE_INT_FIELDS = (
    "num_envs",
    "n_aircraft",
    "buffer_size",
    "train_frequency",
    "batch_size",
    "target_network_frequency",
    "eval_episodes",
    "torch_threads",
    "n_step",
    "explore_hold",
)
"""Integer fields of :class:`TrainConfig` that must be >= 1 (the others must be >= 0)."""
NON_NEGATIVE_INT_FIELDS = (
    "total_samples",
    "iterations",
    "learning_starts",
    "eval_every",
    "checkpoint_every",
    "exploration_samples",
)


@dataclass
class TrainConfig:
    """Hyperparameters of a training run (every field is a ``wildfire train`` option)."""

    approach: str = "obs"
    """``obs`` (sensor image, observation-based reward) or ``belief`` (ego belief, team reward)."""
    arch: str = "paper"
    """Network: ``paper`` (SPEC 2.5); belief only: ``fast`` / ``lite`` (input average-pooled to
    50x50 / 25x25)."""
    seed: int = 1
    """Seed of network initialisation, exploration, replay sampling and training episodes."""
    total_samples: int = 2_835_000
    """Stop after this many aircraft decisions (prefill + 280 000 iterations x 10)."""
    iterations: int = 0
    """If > 0: stop after this many training iterations instead of ``total_samples``."""
    num_envs: int = 16
    """Episodes stepped together."""
    n_aircraft: int = 2
    """Aircraft per training episode."""
    shapes: tuple[str, ...] = ("circular", "arc")
    """Fire shapes of training episodes, drawn uniformly (closed and open fronts mixed)."""
    max_wind: float = EPISODE_DEFAULTS.max_wind
    """Each wind component is uniform in [-max_wind, max_wind] (random wind)."""
    episode_seconds: float = EPISODE_DEFAULTS.duration_s
    """Time limit of an episode (training and evaluation)."""
    buffer_size: int = 70_000
    """Replay capacity in transitions."""
    learning_starts: int = 35_000
    """Random-action samples that prefill the replay before training."""
    train_frequency: int = 10
    """New samples per training iteration."""
    batch_size: int = 64
    """Mini-batch size."""
    gamma: float = 0.99
    """Discount factor."""
    n_step: int = 20
    """Decisions summed in a Bellman target (1: the paper's one-step DQN)."""
    reward_scale: float = 0.01
    """Rewards are multiplied by this in the targets (Q-values of order 1)."""
    learning_rate: float = 2.5e-4
    """AdaMax step size."""
    max_grad_norm: float = 10.0
    """Gradient-norm clip."""
    start_e: float = 1.0
    """Initial exploration probability."""
    end_e: float = 0.1
    """Final exploration probability."""
    exploration_samples: int = 200_000
    """Samples over which epsilon falls linearly from ``start_e`` to ``end_e``."""
    explore_hold: int = 20
    """A random action is held for 1..explore_hold decisions (1: plain epsilon-greedy)."""
    double_q: bool = True
    """Double DQN targets (the online network picks the next action, the target scores it)."""
    target_network_frequency: int = 1000
    """Training iterations between target-network copies."""
    eval_every: int = 10_000
    """Training iterations between evaluations (0: only at the end)."""
    eval_episodes: int = 20
    """Held-out episodes per evaluation."""
    eval_shapes: tuple[str, ...] = ("circular",)
    """Fire shapes of evaluation episodes (the paper's training curve: circular, 2 aircraft)."""
    checkpoint_every: int = 5_000
    """Training iterations between checkpoints (0: only at the end)."""
    torch_threads: int = 1
    """Threads of torch (the machine is shared: 1 or 2)."""
    channels_last: bool = True
    """Run the network in channels-last memory format (~20-40 % faster convolutions here)."""

    def validate(self) -> TrainConfig:
        """Return self, or raise :class:`LearningError` naming the bad field."""
        if self.approach not in IMAGE_SHAPES:
            raise LearningError(f"approach: expected obs or belief, got {self.approach!r}")
        for name in POSITIVE_INT_FIELDS:
            if getattr(self, name) < 1:
                raise LearningError(f"{name}: expected >= 1, got {getattr(self, name)}")
        for name in NON_NEGATIVE_INT_FIELDS:
            if getattr(self, name) < 0:
                raise LearningError(f"{name}: expected >= 0, got {getattr(self, name)}")
        if not 0.0 < self.gamma <= 1.0:
            raise LearningError(f"gamma: expected a number in (0, 1], got {self.gamma}")
        if self.n_step > 255:
            raise LearningError(f"n_step: expected <= 255, got {self.n_step}")
        if not self.reward_scale > 0:
            raise LearningError(f"reward_scale: expected > 0, got {self.reward_scale}")
        if not self.learning_rate > 0:
            raise LearningError(f"learning_rate: expected > 0, got {self.learning_rate}")
        if not 0.0 <= self.end_e <= self.start_e <= 1.0:
            raise LearningError("epsilon: expected 0 <= end_e <= start_e <= 1")
        build_q_network(self.approach, self.arch)  # checks the architecture name
        self.env_config()
        self.eval_env_config()
        return self

    def env_config(self) -> EnvConfig:
        """Environment of training episodes."""
        return EnvConfig(
            n_aircraft=self.n_aircraft,
            observation=self.approach,
            reward=self.approach,
            shapes=tuple(self.shapes),
            max_wind=self.max_wind,
            max_duration_s=self.episode_seconds,
        ).validate()

    def eval_env_config(self) -> EnvConfig:
        """Environment of evaluation episodes (the score is the team reward either way)."""
        return replace(self.env_config(), shapes=tuple(self.eval_shapes))

    def eval_seeds(self) -> list[int]:
        return list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + self.eval_episodes))


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
    """Learning-curve rows (CURVE_FIELDS)."""
    initialised_from: dict[str, Any] | None = None
    """The exported policy a fine-tuning run started from (kept across ``--resume``)."""


@dataclass
class Status:
    """What the progress callback sees."""

    samples: int
    iterations: int
    target_iterations: int
    epsilon: float
    loss: float
    last_score: float | None
    phase: str


@dataclass
class RunOptions:
    """Where and how a run writes its files (not hyperparameters)."""

    run_dir: Path
    out: Path
    resume: bool = False
    baseline_score: float | None = None
    """Receding-horizon score on the evaluation seeds (drawn as a dashed line)."""
    bag_dirs: tuple[Path, ...] = ()
    """Recorded bags whose transitions prefill the replay."""
    offline: bool = False
    """Train on the bag transitions only (no environment interaction)."""
    init_policy: Path | None = None
    """Start from the weights of this exported policy (fine-tuning) instead of random ones."""
    device: str = "cpu"
    """Torch device of the networks and mini-batches (resolved: ``cpu``, ``cuda``, ``cuda:1``)."""


# ------------------------------------------------------------------------------- helpers
def linear_schedule(start_e: float, end_e: float, duration: int, t: int) -> float:
    """Epsilon at sample ``t``: linear from ``start_e`` to ``end_e`` over ``duration``."""
    if duration <= 0:
        return end_e
    slope = (end_e - start_e) / duration
    return max(slope * t + start_e, end_e)


def target_iterations(config: TrainConfig) -> int:
    """Iterations the run will do."""
    if config.iterations > 0:
        return config.iterations
    return max(0, (config.total_samples - config.learning_starts) // config.train_frequency)


def model_device(model: nn.Module) -> torch.device:
    """The device holding ``model``'s weights."""
    return next(model.parameters()).device


def greedy_actions(
    model: nn.Module, images: np.ndarray, states: np.ndarray, channels_last: bool = False
) -> np.ndarray:
    """argmax_a sum_j Q(s_j, a) for a batch: images (B, C, H, W), states (B, K, 5) -> (B,)."""
    device = model_device(model)
    image_tensor = torch.from_numpy(np.ascontiguousarray(images, dtype=np.float32)).to(device)
    if channels_last:
        image_tensor = image_tensor.contiguous(memory_format=torch.channels_last)
    state_tensor = torch.from_numpy(np.ascontiguousarray(states)).to(device)
    with torch.inference_mode():
        q = model(image_tensor, state_tensor)
    return q.sum(dim=1).argmax(dim=1).cpu().numpy()


class GreedyController:
    """The network being trained as an evaluation controller, all aircraft in one batch.

    (Deployment evaluates each ownship alone, see ``QNetworkController``; a batch may pick
    other kernels and so differ in the last bits — fine for a learning curve.)
    """

    def __init__(self, model: nn.Module, observation: str, channels_last: bool = False) -> None:
        self.model = model
        self.observation = observation
        self.channels_last = channels_last

    def reset(self, env: WildfireVecEnv) -> None:
        pass

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        images, states = observations["image"], observations["state"]
        e, n = images.shape[:2]
        actions = greedy_actions(
            self.model,
            images.reshape(e * n, *images.shape[2:]),
            states.reshape(e * n, *states.shape[2:]),
            self.channels_last,
        )
        return actions.reshape(e, n)


def evaluate_greedy(model: nn.Module, config: TrainConfig) -> EvaluationSummary:
    """SPEC 2.7 score of the greedy network on the held-out evaluation seeds."""
    model.eval()
    try:
        controller = GreedyController(model, config.approach, config.channels_last)
        return evaluate(controller, config.eval_env_config(), config.eval_seeds(), "greedy")
    finally:
        model.train()


def td_update(
    q_network: nn.Module,
    target_network: nn.Module,
    optimizer: torch.optim.Optimizer,
    replay: ReplayBuffer,
    config: TrainConfig,
    rng: np.random.Generator,
) -> float:
    """One training iteration on a replay mini-batch; returns the loss."""
    batch = replay.sample(config.batch_size, rng, model_device(q_network))
    images, next_images = batch.images, batch.next_images
    if config.channels_last:
        images = images.contiguous(memory_format=torch.channels_last)
        next_images = next_images.contiguous(memory_format=torch.channels_last)
    with torch.no_grad():
        # Pairwise Q-values are summed over the other aircraft (SPEC 2.5); K = 1 for two.
        next_q = target_network(next_images, batch.next_states).sum(dim=1)
        if config.double_q:
            # Double DQN: the online network picks the next action, the target scores it.
            chosen = q_network(next_images, batch.next_states).sum(dim=1).argmax(dim=1)
            target_max = next_q.gather(1, chosen[:, None]).squeeze(1)
        else:
            target_max = next_q.max(dim=1).values
        bootstrap = config.gamma**batch.steps * (1.0 - batch.terminated)
        td_target = config.reward_scale * batch.rewards + bootstrap * target_max
    q = q_network(images, batch.states).sum(dim=1)
    old_val = q.gather(1, batch.actions[:, None]).squeeze(1)
    loss = F.mse_loss(old_val, td_target)
    optimizer.zero_grad()
    loss.backward()
    nn.utils.clip_grad_norm_(q_network.parameters(), config.max_grad_norm)
    optimizer.step()
    return float(loss.item())


def max_rss_mb() -> float:
    """Peak resident memory of this process (MB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# ------------------------------------------------------------------------ checkpoints
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
        "format": "wildfire-dqn-checkpoint/1",
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
    if not isinstance(payload, dict) or payload.get("format") != "wildfire-dqn-checkpoint/1":
        raise LearningError(f"checkpoint {path}: not a wildfire DQN checkpoint")
    return payload


PRE_EXTENSION_VALUES: dict[str, Any] = {
    "n_step": 1,
    "reward_scale": 1.0,
    "explore_hold": 1,
    "double_q": False,
}
"""Values of fields added after the first runs, for configs saved before them: a resumed run
keeps training the way it started (one-step, unscaled, plain epsilon-greedy, single Q)."""


def upgrade_saved_config(saved: dict[str, Any]) -> dict[str, Any]:
    """A checkpoint's config with the fields it predates set to their original behaviour."""
    return {k: v for k, v in PRE_EXTENSION_VALUES.items() if k not in saved} | saved


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


def config_from_dict(values: dict[str, Any]) -> TrainConfig:
    known = {f.name for f in fields(TrainConfig)}
    kept: dict[str, Any] = {
        k: (tuple(v) if isinstance(v, list) else v) for k, v in values.items() if k in known
    }
    return TrainConfig(**kept)


# ----------------------------------------------------------------------- learning curve
def write_curve(
    run_dir: Path, rows: list[dict[str, float]], baseline: float | None, title: str
) -> None:
    """Learning curve as CSV and PNG (score vs thousands of training iterations)."""
    with open(run_dir / CURVE_CSV, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=CURVE_FIELDS)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: row.get(k, "") for k in CURVE_FIELDS})
    if not rows:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.array([r["iteration"] for r in rows]) / 1000.0
    y = np.array([r["score_mean"] for r in rows])
    err = np.array([r["score_sem"] for r in rows])
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.errorbar(x, y, yerr=err, marker="o", ms=3, capsize=2, color="black", label=title)
    if baseline is not None:
        ax.axhline(baseline, ls="--", color="grey", label="receding horizon")
    ax.set_xlabel("Thousands of Training Iterations")
    ax.set_ylabel("Average Reward Accumulated")
    ax.legend(loc="best")
    fig.tight_layout()
    fig.savefig(run_dir / CURVE_PNG, dpi=110)
    plt.close(fig)


def _init_summary(path: Path) -> dict[str, Any]:
    """What a fine-tuned run started from: the policy file and its own training figures."""
    from wildfire_learning.export import sidecar_path

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
    """The JSON card of an exported policy: what was trained, how long, how well it scored."""
    final = state.curve[-1]
    return {
        "approach": config.approach,
        "arch": config.arch,
        "format": "pairwise Q-network: forward(images (B,C,H,W), states (B,K,5)) -> (B,K,2)",
        "image_shape": list(IMAGE_SHAPES[config.approach]),
        "actions": ["bank -5 deg", "bank +5 deg"],
        "config": asdict(config),
        "iterations": state.iterations,
        "samples": state.samples,
        "wall_time_s": round(state.wall_time_s, 1),
        "initialised_from": state.initialised_from,
        "trained_from_bags": [str(p) for p in options.bag_dirs],
        "bag_transitions": bag_transitions,
        "offline": options.offline,
        "device": options.device,
        "evaluation": {
            "protocol": "SPEC 2.7 team belief reward, greedy network, batched",
            "iteration": int(final["iteration"]),
            "shapes": list(config.eval_shapes),
            "seeds": [config.eval_seeds()[0], config.eval_seeds()[-1]],
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


# ------------------------------------------------------------------------- training
@dataclass
class TrainResult:
    """What a run produced."""

    config: TrainConfig
    state: TrainState
    out: Path
    card: dict[str, Any]
    transitions_from_bags: int
    replay_bytes: int
    samples_per_s: float
    iterations_per_s: float
    prefill_samples_per_s: float
    max_rss_mb: float


def _flat(observations: dict[str, np.ndarray], envs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Images (P, C, H, W) and states (P, K, 5) of every aircraft of ``envs``, env-major."""
    images, states = observations["image"][envs], observations["state"][envs]
    return (images.reshape(-1, *images.shape[2:]), states.reshape(-1, *states.shape[2:]))


def train(
    config: TrainConfig,
    options: RunOptions,
    report: Callable[[Status], None] | None = None,
) -> TrainResult:
    """Run (or resume) a training run; see the module docstring."""
    config.validate()
    run_dir = options.run_dir
    run_dir.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(config.torch_threads)
    approach = config.approach

    # --- seeding, networks, optimizer, replay (or their checkpointed state) -------------
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    device = torch.device(options.device)
    memory_format = torch.channels_last if config.channels_last else torch.contiguous_format
    # torch's stubs omit the memory_format keyword that Module.to accepts.
    q_network = build_q_network(approach, config.arch)
    q_network = q_network.to(device, memory_format=memory_format)  # type: ignore[call-overload]
    target_network = build_q_network(approach, config.arch)
    target_network = target_network.to(device, memory_format=memory_format)  # type: ignore[call-overload]
    optimizer = torch.optim.Adamax(q_network.parameters(), lr=config.learning_rate)
    state = TrainState()
    codec = ImageCodec.for_approach(approach)
    image_shape = IMAGE_SHAPES[approach]
    state_shape = (max(config.n_aircraft - 1, 1), 5)
    replay: ReplayBuffer | None = None
    if options.resume:
        payload = load_checkpoint(run_dir)
        saved = config_from_dict(payload["config"])
        if (saved.approach, saved.arch, saved.n_aircraft) != (
            approach,
            config.arch,
            config.n_aircraft,
        ):
            raise LearningError(
                f"checkpoint {run_dir / CHECKPOINT_FILE}: incompatible (trained {saved.approach}/"
                f"{saved.arch} with {saved.n_aircraft} aircraft, asked {approach}/{config.arch} "
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
    else:
        if options.init_policy is not None:
            load_policy_weights(q_network, options.init_policy, approach, config.arch)
            state.initialised_from = _init_summary(options.init_policy)
        target_network.load_state_dict(q_network.state_dict())

    bag_transitions = 0
    bag_sequences: list[Any] = []
    if options.bag_dirs:
        from wildfire_learning.bag_transitions import transitions_from_bags

        bag_sequences = transitions_from_bags(options.bag_dirs, approach, config.env_config())
        bag_transitions = sum(len(s.actions) for s in bag_sequences)
        if bag_transitions == 0:
            raise LearningError("--from-bag: the bags hold no complete decision to learn from")
    if replay is None:
        capacity = config.buffer_size
        if options.offline:
            capacity = max(capacity, bag_transitions)
        replay = ReplayBuffer(capacity, image_shape, state_shape, codec)
        for sequence in bag_sequences:
            replay.add_sequence(
                sequence.images,
                sequence.states,
                sequence.actions,
                sequence.rewards,
                sequence.terminated,
                encoded=True,
            )
    if replay.image_shape != image_shape or replay.state_shape != state_shape:
        raise LearningError(f"replay {run_dir / REPLAY_FILE}: shapes do not match the network")

    total_iterations = target_iterations(config)
    session_start = time.perf_counter()
    wall_before = state.wall_time_s
    prefill_samples, prefill_start = 0, time.perf_counter()
    prefill_rate = 0.0
    last_score: float | None = state.curve[-1]["score_mean"] if state.curve else None

    def status(phase: str, epsilon: float) -> None:
        if report is not None:
            report(
                Status(
                    state.samples,
                    state.iterations,
                    total_iterations,
                    epsilon,
                    state.last_loss,
                    last_score,
                    phase,
                )
            )

    def checkpoint() -> None:
        state.wall_time_s = wall_before + time.perf_counter() - session_start
        save_checkpoint(run_dir, config, state, q_network, target_network, optimizer, replay, rng)

    def run_evaluation() -> None:
        nonlocal last_score
        status(
            "evaluating",
            linear_schedule(
                config.start_e, config.end_e, config.exploration_samples, state.samples
            ),
        )
        summary = evaluate_greedy(q_network, config).to_json()
        last_score = float(summary["score_mean"])
        state.curve.append(
            {
                "iteration": state.iterations,
                "samples": state.samples,
                "wall_time_s": round(wall_before + time.perf_counter() - session_start, 1),
                "epsilon": linear_schedule(
                    config.start_e, config.end_e, config.exploration_samples, state.samples
                ),
                "score_mean": last_score,
                "score_sem": float(summary["score_sem"]),
                "belief_iou_mean": float(summary["belief_iou_mean"]),
                "episodes": int(summary["episodes"]),
            }
        )
        write_curve(run_dir, state.curve, options.baseline_score, f"{approach} DQN")
        # The latest evaluated network is always on disk (`wildfire eval` it mid-run), and
        # the best-scoring one is kept beside it.
        state.wall_time_s = wall_before + time.perf_counter() - session_start
        card = policy_card(config, state, options, bag_transitions)
        export_policy(q_network, options.out, card)
        best = max(r["score_mean"] for r in state.curve)
        if last_score >= best:
            export_policy(q_network, options.out.with_name("best_" + options.out.name), card)

    def train_step() -> None:
        state.last_loss = td_update(q_network, target_network, optimizer, replay, config, rng)
        state.iterations += 1
        # CleanRL copies the target on global steps; here on training iterations (SPEC 2.5).
        if state.iterations % config.target_network_frequency == 0:
            target_network.load_state_dict(q_network.state_dict())
        if config.eval_every and state.iterations % config.eval_every == 0:
            run_evaluation()
        if config.checkpoint_every and state.iterations % config.checkpoint_every == 0:
            checkpoint()

    train_phase_start: float | None = None
    train_phase_samples0 = state.samples
    train_phase_iterations0 = state.iterations

    try:
        if options.offline:
            # --- offline: iterate on the bag transitions only -------------------------------
            train_phase_start = time.perf_counter()
            while state.iterations < total_iterations:
                train_step()
                if state.iterations % 10 == 0:
                    status("training (offline)", 0.0)
        else:
            # --- online: batched environments, epsilon-greedy, one iteration per N samples --
            env = WildfireVecEnv(config.env_config(), config.num_envs)
            n = config.n_aircraft
            seeds = (state.episodes + np.arange(config.num_envs)) % EVAL_SEED_BASE
            state.episodes += config.num_envs
            observations = env.reset(seeds)
            frame_ids = replay.add_frames(*_flat(observations, np.arange(config.num_envs)))
            frame_ids = frame_ids.reshape(config.num_envs, n)
            pending = NStepAccumulator(config.num_envs, n, config.n_step, config.gamma)
            exploration = PersistentExploration(config.num_envs, n, config.explore_hold)

            def finished() -> bool:
                if config.iterations > 0:
                    return state.iterations >= config.iterations
                return state.samples >= config.total_samples

            while not finished():
                epsilon = linear_schedule(
                    config.start_e, config.end_e, config.exploration_samples, state.samples
                )
                prefilling = len(replay) < config.learning_starts
                # Every aircraft of every environment: one batched forward pass.
                greedy = np.zeros((config.num_envs, n), dtype=np.int64)
                if not prefilling:
                    images, states = _flat(observations, np.arange(config.num_envs))
                    greedy = greedy_actions(q_network, images, states, config.channels_last)
                    greedy = greedy.reshape(config.num_envs, n)
                actions = exploration.actions(greedy, 1.0 if prefilling else epsilon, rng)
                active = np.flatnonzero(~env.done)
                result = env.step(actions)
                observations = result.observations
                # Every aircraft's transition goes to the one replay (the network is shared).
                next_ids = replay.add_frames(*_flat(observations, active)).reshape(-1, n)
                ready = pending.push(
                    active,
                    frame_ids[active],
                    actions[active],
                    result.rewards[active],
                    next_ids,
                    result.terminated[active],
                    env.done[active],
                )
                replay.add_transitions(
                    ready.obs_ids,
                    ready.actions,
                    ready.rewards,
                    ready.terminated,
                    ready.next_ids,
                    ready.steps,
                )
                frame_ids[active] = next_ids
                new_samples = active.size * n
                state.samples += new_samples
                if prefilling:
                    prefill_samples += new_samples
                ended = np.flatnonzero(env.done)
                if ended.size:
                    seeds = (state.episodes + np.arange(ended.size)) % EVAL_SEED_BASE
                    state.episodes += int(ended.size)
                    observations = env.reset(seeds, ended)
                    exploration.reset(ended)
                    frame_ids[ended] = replay.add_frames(*_flat(observations, ended)).reshape(-1, n)

                if len(replay) >= config.learning_starts:
                    if train_phase_start is None:
                        train_phase_start = time.perf_counter()
                        train_phase_samples0 = state.samples
                        train_phase_iterations0 = state.iterations
                        if prefill_samples:
                            prefill_rate = prefill_samples / (train_phase_start - prefill_start)
                    # Iterations owed for the samples since the prefill ended.
                    due = (state.samples - train_phase_samples0) // config.train_frequency
                    while state.iterations - train_phase_iterations0 < due and not (
                        config.iterations > 0 and state.iterations >= config.iterations
                    ):
                        train_step()
                status("prefilling replay" if prefilling else "training", epsilon)
    except KeyboardInterrupt:
        # Ctrl-C or SIGTERM: keep what was learnt, `--resume` continues from here.
        checkpoint()
        raise

    train_wall = time.perf_counter() - train_phase_start if train_phase_start else 0.0
    session_samples = state.samples - train_phase_samples0
    session_iterations = state.iterations - train_phase_iterations0
    state.train_wall_s += train_wall
    state.train_samples += session_samples

    # --- final evaluation, checkpoint, export --------------------------------------------
    if not state.curve or state.curve[-1]["iteration"] != state.iterations:
        run_evaluation()
    checkpoint()
    card = policy_card(config, state, options, bag_transitions)
    export_policy(q_network, options.out, card)
    (run_dir / "train_summary.json").write_text(json.dumps(card, indent=2, default=str) + "\n")
    return TrainResult(
        config=config,
        state=state,
        out=options.out,
        card=card,
        transitions_from_bags=bag_transitions,
        replay_bytes=replay.nbytes,
        samples_per_s=session_samples / train_wall if train_wall > 0 else 0.0,
        iterations_per_s=session_iterations / train_wall if train_wall > 0 else 0.0,
        prefill_samples_per_s=prefill_rate,
        max_rss_mb=max_rss_mb(),
    )


__all__ = [
    "CHECKPOINT_FILE",
    "CURVE_CSV",
    "CURVE_PNG",
    "EVAL_SEED_BASE",
    "NON_NEGATIVE_INT_FIELDS",
    "POSITIVE_INT_FIELDS",
    "REPLAY_FILE",
    "GreedyController",
    "RunOptions",
    "Status",
    "TrainConfig",
    "TrainResult",
    "TrainState",
    "evaluate_greedy",
    "greedy_actions",
    "linear_schedule",
    "load_checkpoint",
    "model_device",
    "policy_card",
    "save_checkpoint",
    "target_iterations",
    "td_update",
    "train",
    "upgrade_saved_config",
]
