"""Scoring the network while it trains, on the validation seeds (``evaluate.py``).

Every evaluation adds a row to the learning curve and exports the network with its card, so
the latest evaluated network is always on disk (``wildfire eval`` it mid-run) and the
best-scoring one beside it (``best_<name>.pt``): training goes on past the best network, and
the validation seeds, which nothing is trained on, pick it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from torch import nn

from wildfire_learning.controllers import GreedyController
from wildfire_learning.evaluate import EvaluationSummary, evaluate
from wildfire_learning.export import export_policy
from wildfire_learning.model_card import policy_card

if TYPE_CHECKING:  # dqn imports this module
    from wildfire_learning.checkpoint import TrainState
    from wildfire_learning.dqn import RunOptions, TrainConfig
    from wildfire_learning.progress import Session


def evaluate_greedy(model: nn.Module, config: TrainConfig) -> EvaluationSummary:
    """Evaluation score of the greedy network on the held-out evaluation seeds."""
    model.eval()
    try:
        controller = GreedyController(model, config.approach, config.channels_last)
        return evaluate(controller, config.eval_env_config(), config.eval_seeds(), "greedy")
    finally:
        model.train()


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

    summary = evaluate_greedy(q_network, config).to_json()
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
        }
    )
    write_curve(options.run_dir, state.curve, options.baseline_score, f"{config.approach} DQN")
    card = policy_card(config, state, options, bag_transitions)
    export_policy(q_network, options.out, card)
    if state.curve[-1]["score_mean"] >= max(r["score_mean"] for r in state.curve):
        export_policy(q_network, options.out.with_name("best_" + options.out.name), card)


__all__ = ["evaluate_and_export", "evaluate_greedy"]
