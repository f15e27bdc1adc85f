"""Evaluation protocol: score = summed team belief reward, over seeded episodes.

See docs/model.md, Evaluation.

All episodes run as one batch (each with its own seed, so results do not depend on how many
run together). Reported per episode: score, flight time, belief IoU at the end (believed
burning vs burning cells), mean belief age at the burning cells at the end, the score
ceiling; and the timings.

The timings count all of a policy's work: ``seconds_per_decision`` is its time before the
flight (``VecPolicy.reset``, where the oracle plans every episode whole) and in flight
(``act``), over the aircraft decisions flown; ``planning_s`` is the part before the flight,
shown apart; ``wall_time_s`` is the whole evaluation (environment, planning and flight).

The score ceiling of an episode (``wildfire_belief.belief.score_ceiling``) is the number of
cells that burn at some decision of the flight and were not believed burning at its start.
No policy can score more. It is not reachable either (cells that ignite far from the
aircraft in the last seconds, cells that burn out before any aircraft gets there), but it
tells how much of the score is still on the table.

Seeds fall in three ranges: training episodes below ``VALIDATION_SEED_BASE``; the
validation range, scored during training to draw the learning curve and keep the best
network; and the test range, which nothing is trained or selected on, for reported results
(``wildfire eval`` defaults to it).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from wildfire_belief.belief import belief_iou, mean_age_at_burning, score_ceiling
from wildfire_learning.summary_stats import standard_error
from wildfire_world.env import EnvConfig, StepResult, VecPolicy, WildfireVecEnv

VALIDATION_SEED_BASE = 1_000_000
"""First validation seed (training seeds stay below)."""
TEST_SEED_BASE = 2_000_000
"""First test seed (never used in training or model selection)."""


@dataclass
class EpisodeRecord:
    """Outcome of one episode."""

    seed: int
    shape: str
    wind: tuple[float, float]
    score: int
    decisions: int
    terminated: bool
    belief_iou: float
    mean_age_burning_s: float
    score_ceiling: int
    """Cells that burned during the flight, not believed burning at its start (score <= this)."""
    false_alarms: int = 0
    """Cells that turned believed burning while not burning (noisy sensing; 0 otherwise)."""
    flipped_fraction: float = 0.0
    """Reports that disagreed with the truth, of all reports (noisy sensing; 0 otherwise)."""
    trajectory: np.ndarray | None = None
    """(decisions + 1, N, 2) positions, if recorded."""
    final_burning: np.ndarray | None = None
    final_affected: np.ndarray | None = None
    final_belief: np.ndarray | None = None


@dataclass
class EvaluationSummary:
    """Outcome of an evaluation run."""

    policy: str
    episodes: list[EpisodeRecord] = field(default_factory=list)
    seconds_per_decision: float = 0.0
    """The policy's time (planning and flight) per aircraft decision."""
    wall_time_s: float = 0.0
    """The whole evaluation: environment, planning and flight."""
    planning_s: float = 0.0
    """Of the policy's time, what it spent before the first decision (the oracle's plans)."""

    @property
    def scores(self) -> np.ndarray:
        return np.array([e.score for e in self.episodes], dtype=np.float64)

    @property
    def score_ceilings(self) -> np.ndarray:
        return np.array([e.score_ceiling for e in self.episodes], dtype=np.float64)

    def to_json(self) -> dict[str, Any]:
        scores = self.scores
        return {
            "policy": self.policy,
            "episodes": len(self.episodes),
            "seeds": [e.seed for e in self.episodes],
            "scores": scores.tolist(),
            "score_mean": float(scores.mean()),
            "score_sem": standard_error(scores),
            "flight_time_s": [e.decisions / 10.0 for e in self.episodes],
            "winds": [list(e.wind) for e in self.episodes],
            "belief_iou_mean": float(np.mean([e.belief_iou for e in self.episodes])),
            "belief_iou": [e.belief_iou for e in self.episodes],
            "false_alarms": [e.false_alarms for e in self.episodes],
            "false_alarms_mean": float(np.mean([e.false_alarms for e in self.episodes])),
            "flipped_fraction": float(np.mean([e.flipped_fraction for e in self.episodes])),
            "mean_age_burning_s": float(np.nanmean([e.mean_age_burning_s for e in self.episodes])),
            "score_ceilings": self.score_ceilings.tolist(),
            "score_ceiling_mean": float(self.score_ceilings.mean()),
            "ceiling_fraction": float(scores.sum() / max(self.score_ceilings.sum(), 1.0)),
            "seconds_per_decision": self.seconds_per_decision,
            "wall_time_s": self.wall_time_s,
            "planning_s": self.planning_s,
        }


def evaluate(
    policy: VecPolicy,
    config: EnvConfig,
    seeds: list[int],
    policy_name: str = "",
    record: bool = False,
    progress: Callable[[int, int], None] | None = None,
    on_step: Callable[[np.ndarray, StepResult], None] | None = None,
) -> EvaluationSummary:
    """Fly ``policy`` on one episode per seed.

    ``progress(done, total)`` is called after every decision with the decisions flown so far,
    ``on_step(active, result)`` with each step's result and the episodes it stepped.
    """
    start = time.perf_counter()
    config = replace(config, observation=policy.observation)
    env = WildfireVecEnv(config, len(seeds))
    observations = env.reset(np.asarray(seeds))
    tic = time.perf_counter()
    policy.reset(env)  # the oracle plans every episode here: part of the policy's time
    planning = time.perf_counter() - tic
    believed_at_start = env.believed().copy()
    if env.sensing is not None:
        # Under noise a cell believed burning at the start can lose that belief and score
        # later (once): every cell that burns during the flight counts toward the ceiling.
        believed_at_start[:] = False
    burned_in_flight = env.truth.astype(bool)
    trajectory = [np.stack([env.aircraft.x_m, env.aircraft.y_m], axis=-1)] if record else []
    policy_seconds = planning
    aircraft_decisions = 0
    while not env.done.all():
        active = ~env.done
        tic = time.perf_counter()
        actions = policy.act(env, observations)
        policy_seconds += time.perf_counter() - tic
        aircraft_decisions += int(active.sum()) * config.n_aircraft
        result = env.step(actions)
        observations = result.observations
        if on_step is not None:
            on_step(active, result)
        # Visits of this decision saw the fire after its step: count what burned then.
        burned_in_flight |= env.truth.astype(bool) & active[:, None, None]
        if record:
            trajectory.append(np.stack([env.aircraft.x_m, env.aircraft.y_m], axis=-1))
        if progress is not None:
            progress(int(env.decisions.max()), config.max_decisions)

    ious = belief_iou(env.believed(), env.fire.burning)
    ages = mean_age_at_burning(env.belief_age_s(), env.fire.burning)
    sensing = env.sensing
    flipped = sensing.flipped_fraction() if sensing is not None else np.zeros(len(seeds))
    affected = env.fire.affected()
    ceilings = score_ceiling(burned_in_flight, believed_at_start)
    wall = time.perf_counter() - start
    summary = EvaluationSummary(
        policy=policy_name,
        seconds_per_decision=policy_seconds / max(aircraft_decisions, 1),
        wall_time_s=wall,
        planning_s=planning,
    )
    path = np.stack(trajectory, axis=1) if record else None  # (E, T + 1, N, 2)
    for e, seed in enumerate(seeds):
        summary.episodes.append(
            EpisodeRecord(
                seed=int(seed),
                shape=env.shapes[e].value,
                wind=(float(env.fire.wind[e, 0]), float(env.fire.wind[e, 1])),
                score=int(env.scores[e]),
                decisions=int(env.decisions[e]),
                terminated=bool(env.terminated[e]),
                belief_iou=float(ious[e]),
                mean_age_burning_s=float(ages[e]),
                score_ceiling=int(ceilings[e]),
                false_alarms=int(sensing.false_alarms[e]) if sensing is not None else 0,
                flipped_fraction=float(flipped[e]),
                trajectory=None if path is None else path[e, : env.decisions[e] + 1],
                final_burning=env.fire.burning[e].copy() if record else None,
                final_affected=affected[e].copy() if record else None,
                final_belief=env.believed()[e].copy() if record else None,
            )
        )
    return summary


__all__ = ["EpisodeRecord", "EvaluationSummary", "evaluate"]
