"""Scoring the network while it trains, on the validation seeds (``evaluate.py``).

Every evaluation adds a row to the learning curve and exports the network with its card, so
the latest evaluated network is always on disk (``wildfire eval`` it mid-run) and the
best-scoring one beside it (``best_<name>.pt``): training goes on past the best network, and
the validation seeds, which nothing is trained on, pick it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from torch import nn

from wildfire_learning.evaluate import EvaluationSummary, evaluate
from wildfire_learning.export import export_policy
from wildfire_learning.model_card import policy_card
from wildfire_learning.train_config import RunOptions, TrainConfig, TrainState
from wildfire_learning.train_status import Session
from wildfire_learning.vec_policies import GreedyVecPolicy
from wildfire_world.env import StepResult

RETURN_TAIL_WEIGHT = 0.01
"""A decision of an episode cut by the time limit counts in the value check only if the
rewards beyond the cut would weigh less than this in its discounted return."""


class ValueCheck(NamedTuple):
    """What the network expects of its greedy decisions against what they collected."""

    predicted: float
    """Mean ``max_a Q`` over the checked decisions (the training targets' units)."""
    collected: float
    """Mean discounted return those decisions collected, scaled as the training targets."""
    decisions: int
    """Aircraft decisions checked."""


def value_check(
    greedy_q: list[np.ndarray],
    rewards: list[np.ndarray],
    active: list[np.ndarray],
    terminated: np.ndarray,
    gamma: float,
    reward_scale: float,
) -> ValueCheck:
    """Compare each greedy decision's predicted value with the return that followed it.

    ``greedy_q`` and ``rewards`` hold one (E, N) array per step, ``active`` one (E,) mask.
    A return is known exactly where the fire ended the episode (nothing follows), and to
    within ``RETURN_TAIL_WEIGHT`` up to that many discounted steps before a time-limit cut.
    Over-estimation, a suspect when a learning curve falls, shows as predicted > collected.
    """
    q, reward = np.stack(greedy_q), reward_scale * np.stack(rewards)  # (T, E, N)
    stepped = np.stack(active)  # (T, E)
    returns = np.empty_like(reward)
    running = np.zeros_like(reward[0])
    for t in range(len(reward) - 1, -1, -1):  # finished episodes add zero rewards
        running = reward[t] + gamma * running
        returns[t] = running
    tail = int(np.ceil(np.log(RETURN_TAIL_WEIGHT) / np.log(gamma)))
    lengths = stepped.sum(axis=0)  # decisions of each episode
    known = stepped & (
        terminated[None, :] | (np.arange(len(reward))[:, None] < lengths[None, :] - tail)
    )
    mask = np.broadcast_to(known[..., None], q.shape)
    return ValueCheck(
        predicted=float(q[mask].mean()) if mask.any() else float("nan"),
        collected=float(returns[mask].mean()) if mask.any() else float("nan"),
        decisions=int(mask.sum()),
    )


def mean_reward(rewards: list[np.ndarray], active: list[np.ndarray]) -> float:
    """Mean training reward per aircraft decision of the stepped episodes.

    ``rewards`` holds one (E, N) array per step, ``active`` one (E,) mask of the episodes
    that step flew. The reward is the approach's own (unscaled): for the observation approach
    it is what the network learns to maximise, not the score, so a learning curve whose score
    falls while this keeps rising points at the reward, not at the learning.
    """
    reward, stepped = np.stack(rewards), np.stack(active)  # (T, E, N), (T, E)
    decisions = int(stepped.sum()) * reward.shape[2]
    return float(reward[stepped].sum() / decisions) if decisions else float("nan")


def evaluate_greedy(
    model: nn.Module, config: TrainConfig
) -> tuple[EvaluationSummary, ValueCheck, float]:
    """Evaluation score of the greedy network on the held-out evaluation seeds, how its
    values compare with the returns its decisions collected there, and the mean training
    reward per aircraft decision it collected (:func:`mean_reward`)."""
    rewards: list[np.ndarray] = []
    active: list[np.ndarray] = []

    def keep(stepped: np.ndarray, result: StepResult) -> None:
        active.append(stepped.copy())
        rewards.append(result.rewards.copy())

    model.eval()
    try:
        policy = GreedyVecPolicy(model, config.approach, config.channels_last)
        summary = evaluate(
            policy, config.eval_env_config(), config.eval_seeds(), "greedy", on_step=keep
        )
    finally:
        model.train()
    terminated = np.array([episode.terminated for episode in summary.episodes])
    check = value_check(
        policy.greedy_q, rewards, active, terminated, config.gamma, config.reward_scale
    )
    return summary, check, mean_reward(rewards, active)


def evaluate_and_export(
    q_network: nn.Module,
    config: TrainConfig,
    options: RunOptions,
    state: TrainState,
    session: Session,
    bag_transitions: int,
) -> None:
    """Score the greedy network, add it to the learning curve (and its files) and export it,
    and as the best network too if no earlier evaluation scored more."""
    # matplotlib loads with the first curve drawn, not with `wildfire train --help`.
    from wildfire_learning.plots import write_curve

    evaluation, values, reward = evaluate_greedy(q_network, config)
    summary = evaluation.to_json()
    state.wall_time_s = session.wall_time_s()
    state.curve.append(
        {
            "iteration": state.iterations,
            "samples": state.samples,
            "wall_time_s": round(state.wall_time_s, 1),
            "epsilon": config.epsilon_at(state.samples),
            "score_mean": float(summary["score_mean"]),
            "score_sem": float(summary["score_sem"]),
            "belief_iou_mean": float(summary["belief_iou_mean"]),
            "episodes": int(summary["episodes"]),
            "q_predicted": round(values.predicted, 4),
            "q_collected": round(values.collected, 4),
            "reward_mean": round(reward, 5),
        }
    )
    write_curve(options.run_dir, state.curve, options.baseline_score, f"{config.approach} DQN")
    card = policy_card(config, state, options, bag_transitions)
    export_policy(q_network, options.out, card)
    if state.curve[-1]["score_mean"] >= max(r["score_mean"] for r in state.curve):
        export_policy(q_network, options.out.with_name("best_" + options.out.name), card)


__all__ = [
    "RETURN_TAIL_WEIGHT",
    "ValueCheck",
    "evaluate_and_export",
    "evaluate_greedy",
    "mean_reward",
    "value_check",
]
