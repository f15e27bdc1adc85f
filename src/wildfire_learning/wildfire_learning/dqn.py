"""Deep Q-learning of the pairwise Q-network (docs/model.md, Q-network), in the shape of
CleanRL's ``dqn.py``: the hyperparameters (``train_config.TrainConfig``; every field is a
``wildfire train`` option, its help in the field's metadata) and one explicit loop
(:func:`train`).

``num_envs`` episodes step together, every aircraft's action from one batched forward pass,
and every aircraft's transition goes to one replay (the network is shared), prefilled with
random actions (``experience.py``). Then one training iteration (mini-batch 64, AdaMax, MSE
Bellman error against a target network copied every 1000 iterations) per ``train_frequency``
new samples, epsilon linear from 1 to ``end_e`` over ``exploration_samples`` samples. The greedy
network is scored on held-out seeds and exported every ``eval_every`` iterations
(``validation.py``), the run saved for ``--resume`` every ``checkpoint_every``
(``checkpoint.py``).

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
* Epsilon falls at the slope of "1 to 0.1 over 200 000 samples" but stops at 0.5, reached
  after 111 111 samples (iteration ~7 600); the paper goes on to 0.1 (the scripts: after
  500 000 samples). Measured on two seeds each (docs/training/dqn.md): with the fall to 0.1
  both seeds' validation score collapsed late (1 782 and 1 635 at 16 000 iterations, from
  peaks of 2 025 and 1 952), the aircraft bunching on the same stretch of front; held at 0.5
  the same seeds scored 2 003 and 1 853 there (+222 and +218, paired) and plateaued. The
  greedy network is what is evaluated and deployed, so the floor costs nothing there.
* Dueling heads (``dueling``) and prioritised replay (``prioritized``), off by default:
  Rainbow's two levers that n-step and double-Q targets leave (q_network.py, replay.py).
* A privileged teacher (``teacher``, off by default): a receding-horizon planner labels the
  states the network's own flights reach, and a large-margin loss on those labels is added
  to the Bellman error, its weight falling to 0 over ``teacher_iterations`` (DAgger's
  labelling, DQfD's loss; see ``teacher.py``).
* Episodes abandoned by an interruption are not resumed: a resumed run starts new episodes
  (their transitions up to the checkpoint are in the replay).
* ``RunOptions.device`` (``--device``) holds the networks, the optimiser and the replay
  mini-batches; the environments are numpy on the CPU, and the replay stays in host memory
  (uint8 frames, copied per mini-batch). The device is not a hyperparameter: a run may resume
  on another one (the card records the last). The exported policy is always a CPU module.
* ``RunOptions.time_limit_s`` (``--time-limit``) ends a session's learning at a wall-clock
  budget instead of only at its target, then evaluates, checkpoints and exports as at the
  end: a run fits a borrowed machine's slot (``scripts/gpu_train.sh``) without a kill, and
  ``--resume`` carries it on. Not a hyperparameter either: the network it stops at depends
  on the machine's speed, and the card's iterations and wall time say where it stopped.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from wildfire_agent.policies import greedy_actions
from wildfire_learning.checkpoint import (
    load_checkpoint,
    load_policy_weights,
    resume,
    save_checkpoint,
)
from wildfire_learning.experience import TrainingEpisodes, bag_sequences, new_replay
from wildfire_learning.export import export_policy
from wildfire_learning.model_card import init_summary, policy_card
from wildfire_learning.replay import ReplayBuffer
from wildfire_learning.scalar_log import ScalarLog
from wildfire_learning.teacher import TeacherStats, agreement, margin_loss
from wildfire_learning.train_config import (
    RunOptions,
    TrainConfig,
    TrainState,
    given_values,
    resolve_config,
)
from wildfire_learning.train_status import Session, Status, max_rss_mb, report_status
from wildfire_learning.validation import evaluate_and_export
from wildfire_msgs_py.stop_signals import stopped


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


def td_update(
    q_network: nn.Module,
    target_network: nn.Module,
    optimizer: torch.optim.Optimizer,
    replay: ReplayBuffer,
    config: TrainConfig,
    rng: np.random.Generator,
    teacher_weight: float = 0.0,
    priority_exponents: tuple[float, float] = (0.0, 0.0),
) -> tuple[float, TeacherStats | None]:
    """One training iteration on a replay mini-batch, on the Bellman error plus
    ``teacher_weight`` times the teacher's margin loss on the labelled states; returns the
    Bellman error (unweighted) and, with a teacher weight, the teacher's figures. The
    mini-batch is prioritised when ``priority_exponents`` (alpha, beta) has alpha > 0: each
    Bellman error is then importance-weighted, and sets its transition's new priority."""
    alpha, beta = priority_exponents
    device = next(q_network.parameters()).device
    batch = replay.sample(config.batch_size, rng, device, alpha, beta)
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
    bellman = F.mse_loss(old_val, td_target)
    loss, teacher = bellman, None
    if alpha > 0:
        errors = old_val - td_target
        loss = (batch.weights * errors.square()).mean()
        replay.update_priorities(batch.slots, errors.detach().cpu().numpy())
    if teacher_weight > 0:
        pull = margin_loss(q, batch.labels, config.teacher_margin)
        loss = loss + teacher_weight * pull
        teacher = TeacherStats(pull.item(), teacher_weight, agreement(q, batch.labels))
    optimizer.zero_grad()
    loss.backward()
    nn.utils.clip_grad_norm_(q_network.parameters(), config.max_grad_norm)
    optimizer.step()
    return float(bellman.item()), teacher


def train(
    config: TrainConfig | Mapping[str, Any],
    options: RunOptions,
    report: Callable[[Status], None] | None = None,
) -> TrainResult:
    """Run (or resume) a training run; see the module docstring.

    ``config`` is a :class:`TrainConfig`, or the values given explicitly as a mapping of its
    field names. A resumed run (``options.resume``) trains with ``resolve_config``'s merge:
    defaults < its checkpoint's config < the values given, those of a :class:`TrainConfig`
    being the fields that differ from their defaults (a mapping can also give a default back).
    The config trained with is :attr:`TrainResult.config`.
    """
    run_dir = options.run_dir
    checkpoint = load_checkpoint(run_dir) if options.resume else None
    if checkpoint is not None or not isinstance(config, TrainConfig):
        saved = checkpoint["config"] if checkpoint is not None else None
        config = resolve_config(saved, given_values(config))
    config.validate()
    run_dir.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(config.torch_threads)
    n, num_envs = config.n_aircraft, config.num_envs

    # --- seeding, networks, optimiser: a checkpoint then overwrites what it saved ----------
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    device = torch.device(options.device)
    memory_format = torch.channels_last if config.channels_last else torch.contiguous_format
    # torch's stubs omit the memory_format keyword that Module.to accepts.
    q_network = config.q_network()
    q_network = q_network.to(device, memory_format=memory_format)  # type: ignore[call-overload]
    target_network = config.q_network()
    target_network = target_network.to(device, memory_format=memory_format)  # type: ignore[call-overload]
    optimizer = torch.optim.Adamax(q_network.parameters(), lr=config.learning_rate)
    replay: ReplayBuffer | None = None
    if checkpoint is not None:
        state, replay = resume(
            run_dir, checkpoint, config, q_network, target_network, optimizer, rng
        )
    else:
        state = TrainState()
        if options.init_policy is not None:
            load_policy_weights(q_network, options.init_policy, config)
            state.initialised_from = init_summary(options.init_policy)
        target_network.load_state_dict(q_network.state_dict())

    # --- replay: the checkpoint's, or a new one holding the bag transitions first ----------
    sequences = bag_sequences(config, options.bag_dirs)
    bag_transitions = sum(len(s.actions) for s in sequences)
    if replay is None:
        # Offline the bags are all there is to learn from: the replay keeps all of them.
        replay = new_replay(
            config, max(config.buffer_size, bag_transitions if options.offline else 0), sequences
        )

    session = Session(state.wall_time_s, state.samples, state.iterations)
    episodes: TrainingEpisodes | None = None
    if options.offline:  # no environment: the loop only learns, one iteration per pass
        session.start_training(state)
    else:
        episodes = TrainingEpisodes(config, replay, state, rng)
    total_iterations = config.target_iterations()
    # Offline runs, and runs given ``iterations``, stop on iterations; the others on samples.
    by_iterations = options.offline or config.iterations > 0
    # TensorBoard scalars beside the CSV curve; closed (flushed) however the session ends.
    with ScalarLog(run_dir) as scalars:
        try:
            while (
                state.iterations < total_iterations
                if by_iterations
                else state.samples < config.total_samples
            ) and not session.out_of_time(options.time_limit_s):
                if episodes is None:
                    epsilon, phase, owed = 0.0, "training (offline)", state.iterations + 1
                else:
                    # --- act: every aircraft of every environment, one forward pass -----------
                    epsilon = config.epsilon_at(state.samples)
                    prefilling = len(replay) < config.learning_starts
                    phase = "prefilling replay" if prefilling else "training"
                    greedy = np.zeros((num_envs, n), dtype=np.int64)
                    if not prefilling:
                        images, pair_states = episodes.aircraft()
                        greedy = greedy_actions(
                            q_network, images, pair_states, config.channels_last
                        )
                        greedy = greedy.reshape(num_envs, n)
                    actions = episodes.exploration.actions(
                        greedy, 1.0 if prefilling else epsilon, rng
                    )
                    # --- step and store: every aircraft's transition goes to the one replay ---
                    taken = episodes.step(actions, replay, state)
                    state.samples += taken
                    if prefilling:
                        session.prefill_samples += taken
                    owed = state.iterations
                    if len(replay) >= config.learning_starts:
                        session.start_training(state)
                        # One iteration per train_frequency samples since the prefill ended.
                        since = state.samples - session.samples0
                        owed = session.iterations0 + since // config.train_frequency
                if config.iterations > 0:
                    owed = min(owed, config.iterations)

                # --- learn: the iterations owed, target copies, evaluations, checkpoints -------
                while state.iterations < owed:
                    state.last_loss, teacher = td_update(
                        q_network,
                        target_network,
                        optimizer,
                        replay,
                        config,
                        rng,
                        config.teacher_weight_at(state.iterations),
                        config.priority_exponents_at(state.iterations),
                    )
                    state.iterations += 1
                    scalars.training(state, epsilon, session.training_rates(state), teacher)
                    # CleanRL copies the target on global steps; here on training iterations,
                    # as in the paper (docs/model.md, Q-network).
                    if state.iterations % config.target_network_frequency == 0:
                        target_network.load_state_dict(q_network.state_dict())
                    if config.eval_every and state.iterations % config.eval_every == 0:
                        report_status(report, state, config, "evaluating")
                        evaluate_and_export(
                            q_network, config, options, state, session, bag_transitions
                        )
                        scalars.evaluation(state.curve[-1])
                    if config.checkpoint_every and state.iterations % config.checkpoint_every == 0:
                        state.wall_time_s = session.wall_time_s()
                        save_checkpoint(
                            run_dir,
                            config,
                            state,
                            q_network,
                            target_network,
                            optimizer,
                            replay,
                            rng,
                        )
                if episodes is not None or state.iterations % 10 == 0:  # offline: every 10th pass
                    report_status(report, state, config, phase, epsilon)
        except (KeyboardInterrupt, SystemError) as error:
            if not stopped(error):
                raise
            # Ctrl-C or SIGTERM (also one that landed inside a compiled kernel): keep what
            # was learnt, `--resume` continues from here.
            state.wall_time_s = session.wall_time_s()
            save_checkpoint(
                run_dir, config, state, q_network, target_network, optimizer, replay, rng
            )
            raise
        samples_per_s, iterations_per_s = session.close(state)

        # --- final evaluation, checkpoint, export -------------------------------------------------
        if not state.curve or state.curve[-1]["iteration"] != state.iterations:
            report_status(report, state, config, "evaluating")
            evaluate_and_export(q_network, config, options, state, session, bag_transitions)
            scalars.evaluation(state.curve[-1])
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
        samples_per_s=samples_per_s,
        iterations_per_s=iterations_per_s,
        prefill_samples_per_s=session.prefill_rate,
        max_rss_mb=max_rss_mb(),
    )


__all__ = ["TrainResult", "td_update", "train"]
