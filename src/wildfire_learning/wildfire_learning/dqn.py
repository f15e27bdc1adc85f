"""Deep Q-learning of the pairwise Q-network, in the style of CleanRL's ``dqn.py``.

The model it learns is described in docs/model.md, Q-network.

One explicit loop: batched environments (``num_envs`` episodes of two aircraft stepping
together, actions of every aircraft from one batched forward pass), every aircraft's
transition stored in one replay (the network is shared), the replay prefilled with random
actions, then one training iteration (mini-batch 64, AdaMax, MSE Bellman error against a
target network copied every 1000 iterations) per ``train_frequency`` new samples, epsilon
linear from 1 to 0.1 over ``exploration_samples`` samples. Every ``eval_every`` iterations
the greedy network is scored with the evaluation protocol (docs/model.md, Evaluation) on
fixed held-out seeds (``eval_seed_base`` and up; training episodes use seeds below it), the
learning curve is written (CSV + PNG) and a checkpoint (networks, optimizer, replay, RNG
states, counters) is saved so ``--resume`` continues where the run stopped
(``checkpoint.py``). At the end the network is exported as a TorchScript policy
(``export.py``) with its JSON card (``model_card.py``). This module holds the
hyperparameters and the loop; every field of :class:`TrainConfig` is a ``wildfire train``
option, its help text in the field's metadata.

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

import json
import resource
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from wildfire_agent.approaches import APPROACHES
from wildfire_agent.policies import greedy_actions
from wildfire_learning.architectures import ARCHITECTURES, IMAGE_SHAPES, build_q_network
from wildfire_learning.checkpoint import (
    REPLAY_FILE,
    TrainState,
    load_policy_weights,
    resume,
    save_checkpoint,
    write_curve,
)
from wildfire_learning.controllers import GreedyController
from wildfire_learning.env import EnvConfig, WildfireVecEnv
from wildfire_learning.errors import LearningError
from wildfire_learning.evaluate import VALIDATION_SEED_BASE, EvaluationSummary, evaluate
from wildfire_learning.exploration import PersistentExploration
from wildfire_learning.export import export_policy
from wildfire_learning.model_card import init_summary, policy_card
from wildfire_learning.nstep import NStepAccumulator
from wildfire_learning.replay import ImageCodec, ReplayBuffer
from wildfire_sim.episode import EPISODE_DEFAULTS

EVAL_SEED_BASE = VALIDATION_SEED_BASE
"""Evaluation seeds during training start here; training seeds stay below."""


def hyperparameter(default: Any, help: str, **option: Any) -> Any:
    """A :class:`TrainConfig` field: its default and the help of its ``wildfire train`` option.

    ``option`` may hold ``name`` (the option's name when not the field's), ``choices``,
    ``min`` (integers: the smallest valid value, checked by :meth:`TrainConfig.validate`) and
    ``unit`` (floats: True for a value in [0, 1]; other floats must be > 0 on the command line).
    """
    return field(default=default, metadata={"help": help, **option})


@dataclass
class TrainConfig:
    """Hyperparameters of a training run (every field is a ``wildfire train`` option)."""

    approach: str = hyperparameter(
        "obs",
        "``obs`` (sensor image, observation-based reward) or ``belief`` (ego belief, team reward).",
        choices=APPROACHES,
    )
    arch: str = hyperparameter(
        "paper",
        "Network: ``paper`` (the paper's); belief only: ``fast`` / ``lite`` (input average-pooled "
        "to 50x50 / 25x25).",
        choices=ARCHITECTURES,
    )
    seed: int = hyperparameter(
        1,
        "Seed of network initialisation, exploration, replay sampling and training episodes.",
        min=0,
    )
    total_samples: int = hyperparameter(
        2_835_000,
        "Stop after this many aircraft decisions (prefill + 280 000 iterations x 10).",
        min=0,
    )
    iterations: int = hyperparameter(
        0, "If > 0: stop after this many training iterations instead of ``total_samples``.", min=0
    )
    num_envs: int = hyperparameter(16, "Episodes stepped together.", min=1)
    n_aircraft: int = hyperparameter(2, "Aircraft per training episode.", min=1)
    shapes: tuple[str, ...] = hyperparameter(
        ("circular", "arc"),
        "Fire shapes of training episodes, drawn uniformly (closed and open fronts mixed).",
    )
    max_wind: float = hyperparameter(
        EPISODE_DEFAULTS.max_wind,
        "Each wind component is uniform in [-max_wind, max_wind] (random wind).",
        unit=True,
    )
    episode_seconds: float = hyperparameter(
        EPISODE_DEFAULTS.duration_s, "Time limit of an episode (training and evaluation)."
    )
    buffer_size: int = hyperparameter(70_000, "Replay capacity in transitions.", min=1)
    learning_starts: int = hyperparameter(
        35_000, "Random-action samples that prefill the replay before training.", min=0
    )
    train_frequency: int = hyperparameter(10, "New samples per training iteration.", min=1)
    batch_size: int = hyperparameter(64, "Mini-batch size.", min=1)
    gamma: float = hyperparameter(0.99, "Discount factor.", unit=True)
    n_step: int = hyperparameter(
        20, "Decisions summed in a Bellman target (1: the paper's one-step DQN).", min=1
    )
    reward_scale: float = hyperparameter(
        0.01, "Rewards are multiplied by this in the targets (Q-values of order 1)."
    )
    learning_rate: float = hyperparameter(2.5e-4, "AdaMax step size.", name="lr")
    max_grad_norm: float = hyperparameter(10.0, "Gradient-norm clip.")
    start_e: float = hyperparameter(1.0, "Initial exploration probability.", unit=True)
    end_e: float = hyperparameter(0.1, "Final exploration probability.", unit=True)
    exploration_samples: int = hyperparameter(
        200_000,
        "Samples over which epsilon falls linearly from ``start_e`` to ``end_e``.",
        min=0,
    )
    explore_hold: int = hyperparameter(
        20,
        "A random action is held for 1..explore_hold decisions (1: plain epsilon-greedy).",
        min=1,
    )
    double_q: bool = hyperparameter(
        True,
        "Double DQN targets (the online network picks the next action, the target scores it).",
    )
    target_network_frequency: int = hyperparameter(
        1000, "Training iterations between target-network copies.", min=1
    )
    eval_every: int = hyperparameter(
        10_000, "Training iterations between evaluations (0: only at the end).", min=0
    )
    eval_episodes: int = hyperparameter(20, "Held-out episodes per evaluation.", min=1)
    eval_shapes: tuple[str, ...] = hyperparameter(
        ("circular",),
        "Fire shapes of evaluation episodes (the paper's training curve: circular, 2 aircraft).",
    )
    checkpoint_every: int = hyperparameter(
        5_000, "Training iterations between checkpoints (0: only at the end).", min=0
    )
    torch_threads: int = hyperparameter(
        1, "Threads of torch (the machine is shared: 1 or 2).", min=1
    )
    channels_last: bool = hyperparameter(
        True, "Run the network in channels-last memory format (~20-40 % faster convolutions here)."
    )

    def validate(self) -> TrainConfig:
        """Return self, or raise :class:`LearningError` naming the bad field."""
        if self.approach not in IMAGE_SHAPES:
            raise LearningError(f"approach: expected obs or belief, got {self.approach!r}")
        for spec in fields(self):
            least = spec.metadata.get("min")
            if least is not None and getattr(self, spec.name) < least:
                raise LearningError(
                    f"{spec.name}: expected >= {least}, got {getattr(self, spec.name)}"
                )
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


def config_from_dict(values: dict[str, Any]) -> TrainConfig:
    """A config from saved or given values (lists read as tuples, unknown keys ignored)."""
    known = {f.name for f in fields(TrainConfig)}
    kept: dict[str, Any] = {
        k: (tuple(v) if isinstance(v, list) else v) for k, v in values.items() if k in known
    }
    return TrainConfig(**kept)


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


# ------------------------------------------------------------------------------- helpers
def linear_schedule(start_e: float, end_e: float, duration: int, t: int) -> float:
    """Epsilon at sample ``t``: linear from ``start_e`` to ``end_e`` over ``duration``."""
    if duration <= 0:
        return end_e
    slope = (end_e - start_e) / duration
    return max(slope * t + start_e, end_e)


def epsilon_at(config: TrainConfig, samples: int) -> float:
    """Exploration probability after ``samples`` samples."""
    return linear_schedule(config.start_e, config.end_e, config.exploration_samples, samples)


def target_iterations(config: TrainConfig) -> int:
    """Iterations the run will do."""
    if config.iterations > 0:
        return config.iterations
    return max(0, (config.total_samples - config.learning_starts) // config.train_frequency)


def model_device(model: nn.Module) -> torch.device:
    """The device holding ``model``'s weights."""
    return next(model.parameters()).device


def max_rss_mb() -> float:
    """Peak resident memory of this process (MB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def evaluate_greedy(model: nn.Module, config: TrainConfig) -> EvaluationSummary:
    """Evaluation score of the greedy network on the held-out evaluation seeds."""
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
        # Pairwise Q-values are summed over the other aircraft (docs/model.md, Q-network);
        # K = 1 for two.
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


@dataclass
class Session:
    """Wall-clock bookkeeping of one session of a run (a resumed run starts a new one)."""

    wall_before_s: float
    """Wall time of the run's earlier sessions."""
    samples0: int
    """Samples when the training phase started (after the prefill)."""
    iterations0: int
    """Iterations when the training phase started."""
    start: float = field(default_factory=time.perf_counter)
    train_start: float | None = None
    prefill_samples: int = 0
    prefill_rate: float = 0.0

    def wall_time_s(self) -> float:
        """Wall time of the run so far, earlier sessions included."""
        return self.wall_before_s + time.perf_counter() - self.start

    def start_training(self, state: TrainState) -> None:
        """Mark the end of the prefill (once): training-phase rates count from here."""
        if self.train_start is not None:
            return
        self.train_start = time.perf_counter()
        self.samples0, self.iterations0 = state.samples, state.iterations
        if self.prefill_samples:
            self.prefill_rate = self.prefill_samples / (self.train_start - self.start)


def evaluate_and_export(
    q_network: nn.Module,
    config: TrainConfig,
    options: RunOptions,
    state: TrainState,
    session: Session,
    bag_transitions: int,
) -> None:
    """Score the greedy network, add it to the learning curve and export it: the latest
    evaluated network is always on disk (`wildfire eval` it mid-run), the best-scoring one
    beside it."""
    summary = evaluate_greedy(q_network, config).to_json()
    state.wall_time_s = session.wall_time_s()
    state.curve.append(
        {
            "iteration": state.iterations,
            "samples": state.samples,
            "wall_time_s": round(state.wall_time_s, 1),
            "epsilon": epsilon_at(config, state.samples),
            "score_mean": float(summary["score_mean"]),
            "score_sem": float(summary["score_sem"]),
            "belief_iou_mean": float(summary["belief_iou_mean"]),
            "episodes": int(summary["episodes"]),
        }
    )
    write_curve(options.run_dir, state.curve, options.baseline_score, f"{config.approach} DQN")
    card = policy_card(config, state, options, bag_transitions)
    export_policy(q_network, options.out, card)
    if state.curve[-1]["score_mean"] >= max(r["score_mean"] for r in state.curve):
        export_policy(q_network, options.out.with_name("best_" + options.out.name), card)


@dataclass
class Episodes:
    """The training episodes of an online run and what the loop carries between decisions."""

    env: WildfireVecEnv
    observations: dict[str, np.ndarray]
    frame_ids: np.ndarray
    """(E, N) replay frame of every aircraft's current observation."""
    pending: NStepAccumulator
    exploration: PersistentExploration


def report_status(
    report: Callable[[Status], None] | None,
    state: TrainState,
    config: TrainConfig,
    phase: str,
    epsilon: float | None = None,
) -> None:
    """Tell the progress callback (``epsilon`` defaults to the schedule's)."""
    if report is not None:
        report(
            Status(
                state.samples,
                state.iterations,
                target_iterations(config),
                epsilon_at(config, state.samples) if epsilon is None else epsilon,
                state.last_loss,
                state.last_score,
                phase,
            )
        )


def next_training_seeds(state: TrainState, count: int) -> np.ndarray:
    """Seeds of the next ``count`` training episodes (below the evaluation seeds)."""
    seeds = (state.episodes + np.arange(count)) % EVAL_SEED_BASE
    state.episodes += count
    return seeds


def flat_aircraft(
    observations: dict[str, np.ndarray], envs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Images (P, C, H, W) and states (P, K, 5) of every aircraft of ``envs``, env-major."""
    images, states = observations["image"][envs], observations["state"][envs]
    return (images.reshape(-1, *images.shape[2:]), states.reshape(-1, *states.shape[2:]))


def bag_replay_sequences(config: TrainConfig, options: RunOptions) -> list[Any]:
    """Transitions rebuilt from ``options.bag_dirs`` (none without bags)."""
    if not options.bag_dirs:
        return []
    from wildfire_learning.bag_transitions import transitions_from_bags

    sequences = transitions_from_bags(options.bag_dirs, config.approach, config.env_config())
    if sum(len(s.actions) for s in sequences) == 0:
        raise LearningError("--from-bag: the bags hold no complete decision to learn from")
    return sequences


# ------------------------------------------------------------------------- training
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
    n = config.n_aircraft
    everyone = np.arange(config.num_envs)

    # --- seeding, networks, optimiser: a checkpoint then overwrites what it saved ----------
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    device = torch.device(options.device)
    memory_format = torch.channels_last if config.channels_last else torch.contiguous_format
    # torch's stubs omit the memory_format keyword that Module.to accepts.
    q_network = build_q_network(config.approach, config.arch)
    q_network = q_network.to(device, memory_format=memory_format)  # type: ignore[call-overload]
    target_network = build_q_network(config.approach, config.arch)
    target_network = target_network.to(device, memory_format=memory_format)  # type: ignore[call-overload]
    optimizer = torch.optim.Adamax(q_network.parameters(), lr=config.learning_rate)
    replay: ReplayBuffer | None = None
    if options.resume:
        state, replay = resume(run_dir, config, q_network, target_network, optimizer, rng)
    else:
        state = TrainState()
        if options.init_policy is not None:
            load_policy_weights(q_network, options.init_policy, config.approach, config.arch)
            state.initialised_from = init_summary(options.init_policy)
        target_network.load_state_dict(q_network.state_dict())

    # --- replay: the checkpoint's, or a new one holding the bag transitions first ----------
    bag_sequences = bag_replay_sequences(config, options)
    bag_transitions = sum(len(s.actions) for s in bag_sequences)
    image_shape, state_shape = IMAGE_SHAPES[config.approach], (max(n - 1, 1), 5)
    if replay is None:
        capacity = max(config.buffer_size, bag_transitions if options.offline else 0)
        replay = ReplayBuffer(
            capacity, image_shape, state_shape, ImageCodec.for_approach(config.approach)
        )
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
    session = Session(state.wall_time_s, state.samples, state.iterations)
    episodes: Episodes | None = None  # offline: no environment, one iteration per pass
    if options.offline:
        session.start_training(state)
    else:
        env = WildfireVecEnv(config.env_config(), config.num_envs)
        observations = env.reset(next_training_seeds(state, config.num_envs))
        frame_ids = replay.add_frames(*flat_aircraft(observations, everyone))
        episodes = Episodes(
            env,
            observations,
            frame_ids.reshape(config.num_envs, n),
            NStepAccumulator(config.num_envs, n, config.n_step, config.gamma),
            PersistentExploration(config.num_envs, n, config.explore_hold),
        )

    try:
        while not (
            state.iterations >= total_iterations
            if options.offline or config.iterations > 0
            else state.samples >= config.total_samples
        ):
            # --- act and store: every aircraft of every environment, one forward pass --------
            if episodes is None:
                epsilon, phase = 0.0, "training (offline)"
                owed = state.iterations + 1
            else:
                epsilon = epsilon_at(config, state.samples)
                prefilling = len(replay) < config.learning_starts
                phase = "prefilling replay" if prefilling else "training"
                greedy = np.zeros((config.num_envs, n), dtype=np.int64)
                if not prefilling:
                    images, pair_states = flat_aircraft(episodes.observations, everyone)
                    greedy = greedy_actions(q_network, images, pair_states, config.channels_last)
                    greedy = greedy.reshape(config.num_envs, n)
                actions = episodes.exploration.actions(greedy, 1.0 if prefilling else epsilon, rng)
                env = episodes.env
                active = np.flatnonzero(~env.done)
                result = env.step(actions)
                episodes.observations = result.observations
                # Every aircraft's transition goes to the one replay (the network is shared).
                next_ids = replay.add_frames(*flat_aircraft(result.observations, active))
                next_ids = next_ids.reshape(-1, n)
                ready = episodes.pending.push(
                    active,
                    episodes.frame_ids[active],
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
                episodes.frame_ids[active] = next_ids
                state.samples += active.size * n
                if prefilling:
                    session.prefill_samples += active.size * n
                ended = np.flatnonzero(env.done)
                if ended.size:
                    episodes.observations = env.reset(
                        next_training_seeds(state, int(ended.size)), ended
                    )
                    episodes.exploration.reset(ended)
                    ended_ids = replay.add_frames(*flat_aircraft(episodes.observations, ended))
                    episodes.frame_ids[ended] = ended_ids.reshape(-1, n)
                owed = state.iterations
                if len(replay) >= config.learning_starts:
                    session.start_training(state)
                    # Iterations owed for the samples since the prefill ended.
                    since = state.samples - session.samples0
                    owed = session.iterations0 + since // config.train_frequency
            if config.iterations > 0:
                owed = min(owed, config.iterations)

            # --- learn ------------------------------------------------------------------
            while state.iterations < owed:
                state.last_loss = td_update(
                    q_network, target_network, optimizer, replay, config, rng
                )
                state.iterations += 1
                # CleanRL copies the target on global steps; here on training iterations,
                # as in the paper (docs/model.md, Q-network).
                if state.iterations % config.target_network_frequency == 0:
                    target_network.load_state_dict(q_network.state_dict())
                if config.eval_every and state.iterations % config.eval_every == 0:
                    report_status(report, state, config, "evaluating")
                    evaluate_and_export(q_network, config, options, state, session, bag_transitions)
                if config.checkpoint_every and state.iterations % config.checkpoint_every == 0:
                    state.wall_time_s = session.wall_time_s()
                    save_checkpoint(
                        run_dir, config, state, q_network, target_network, optimizer, replay, rng
                    )
            if episodes is not None or state.iterations % 10 == 0:
                report_status(report, state, config, phase, epsilon)
    except KeyboardInterrupt:
        # Ctrl-C or SIGTERM: keep what was learnt, `--resume` continues from here.
        state.wall_time_s = session.wall_time_s()
        save_checkpoint(run_dir, config, state, q_network, target_network, optimizer, replay, rng)
        raise

    train_wall = time.perf_counter() - session.train_start if session.train_start else 0.0
    session_samples = state.samples - session.samples0
    session_iterations = state.iterations - session.iterations0
    state.train_wall_s += train_wall
    state.train_samples += session_samples

    # --- final evaluation, checkpoint, export -------------------------------------------------
    if not state.curve or state.curve[-1]["iteration"] != state.iterations:
        report_status(report, state, config, "evaluating")
        evaluate_and_export(q_network, config, options, state, session, bag_transitions)
    state.wall_time_s = session.wall_time_s()
    save_checkpoint(run_dir, config, state, q_network, target_network, optimizer, replay, rng)
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
        prefill_samples_per_s=session.prefill_rate,
        max_rss_mb=max_rss_mb(),
    )


__all__ = [
    "EVAL_SEED_BASE",
    "RunOptions",
    "Status",
    "TrainConfig",
    "TrainResult",
    "config_from_dict",
    "epsilon_at",
    "evaluate_and_export",
    "evaluate_greedy",
    "hyperparameter",
    "linear_schedule",
    "model_device",
    "report_status",
    "target_iterations",
    "td_update",
    "train",
]
