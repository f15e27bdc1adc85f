"""A privileged teacher for DQN training: the receding-horizon planner labels the student's
own states, and a large-margin loss pulls the network towards its choices (``--teacher``).

This is DAgger's labelling with DQfD's loss. The student (the network being trained, with
its exploration) flies every training episode; at each decision the teacher plans afresh
from where each aircraft now is, on the map it would plan on (the true fire for ``rh`` and
``rh-paper``, the team's believed map for ``rh-belief``), and the first action of its plan
is that state's label. The teacher never flies, so the labels cover the states the student
actually reaches, not only the teacher's own flights (the distribution shift that plain
behaviour cloning suffers). Each label is stored with its observation frame in the replay.

The loss on a labelled state (Hester et al., "Deep Q-learning from Demonstrations"):
``max_a [Q(s, a) + margin * (a != label)] - Q(s, label)``, zero once the label's value leads
the other action by ``margin``. It is added to the Bellman error with a weight that falls
linearly to zero over ``teacher_iterations``: first the network learns to decide as the
teacher does, with values the Bellman targets keep calibrated; then the team reward alone
decides, so the student can move past a teacher that sees the truth but plans each aircraft
alone over 6 s.

``oracle`` teaches the same way (:class:`OracleTeacher`): at every decision it re-plans the
team from where the aircraft now are, on the episode's known future, with the cells the team
has already scored counted as covered, and labels each aircraft with its plan's first
action. It is the oracle's own re-plan (``oracle.replan_team``) without the incumbents and the
whole-episode refinement; its labels cost about ten times the ``rh`` teacher's
(docs/training/dqn.md)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch

from wildfire_agent.dynamics import AircraftState
from wildfire_agent.policy_names import ORACLE_POLICY, PLANNER_POLICIES, planner_config
from wildfire_agent.receding_horizon import plan
from wildfire_learning.oracle import (
    KnownFuture,
    OracleConfig,
    first_plan,
    known_future,
    poses,
    replan_team,
)
from wildfire_learning.oracle_kernels import NEVER
from wildfire_learning.vec_policies import flatten_aircraft, map_index, others_of
from wildfire_sim.seeding import Stream, generator
from wildfire_world.env import WildfireVecEnv


class PlannerTeacher:
    """Labels the aircraft of a :class:`WildfireVecEnv` with a planner's next action."""

    def __init__(self, name: str, rng: np.random.Generator) -> None:
        config = planner_config(name)
        if config is None:
            expected = ", ".join(PLANNER_POLICIES)
            raise ValueError(f"teacher: expected one of {expected}, got {name!r}")
        self.config = config
        # The planner's random restarts come from the run's own generator, which a checkpoint
        # saves, so a resumed run labels exactly as an uninterrupted one.
        self.rng = rng

    def labels(self, env: WildfireVecEnv, envs: np.ndarray) -> np.ndarray:
        """The teacher's action (P,) int8 for each aircraft of the episodes ``envs`` (P = E * N,
        env-major, as the replay stores their frames)."""
        n = env.config.n_aircraft
        envs = np.asarray(envs, dtype=np.int64)
        aircraft = (envs[:, None] * n + np.arange(n)).reshape(-1)
        if aircraft.size == 0:
            return np.zeros(0, dtype=np.int8)
        own = flatten_aircraft(env.aircraft)
        others = others_of(env.team_views())
        own = AircraftState(*(field[aircraft] for field in own))
        others = AircraftState(*(field[aircraft] for field in others))
        believed = self.config.believed_map
        sequences = plan(
            own,
            others,
            map_index(env, believed)[aircraft],
            env.believed_maps() if believed else env.maps,
            [self.rng] * aircraft.size,
            self.config,
            env.config.obs_weights,
        )
        return sequences[:, 0].astype(np.int8)


class _OracleEpisode(NamedTuple):
    """What the oracle teacher keeps of one environment's episode."""

    future: KnownFuture
    plan: np.ndarray
    """(N, decisions + T + tau) the team's current plan, the warm start of the next re-plan."""
    rngs: dict[int, np.random.Generator]
    """Each aircraft's random restarts, the streams the oracle's own search draws from."""


class OracleTeacher:
    """Labels the aircraft of a :class:`WildfireVecEnv` with the clairvoyant planner's next
    action (see the module docstring). Only for the paper's world (ideal links, disc sensing),
    where the team's score is the oracle's coverage count."""

    def __init__(self, config: OracleConfig | None = None) -> None:
        self.config = config or OracleConfig(incumbents=())
        self.episodes: dict[int, _OracleEpisode] = {}
        """By environment, the episode it flies now (replaced when its seed changes)."""

    def _episode(self, env: WildfireVecEnv, e: int) -> _OracleEpisode:
        seed = int(env.seeds[e])
        kept = self.episodes.get(e)
        if kept is not None and kept.future.seed == seed:
            return kept
        future = known_future(seed, env.config)
        n = env.config.n_aircraft
        plan = first_plan(future, self.config)
        rngs = {k: generator(seed, Stream.AIRCRAFT, k) for k in range(n)}
        self.episodes[e] = _OracleEpisode(future, plan, rngs)
        return self.episodes[e]

    def labels(self, env: WildfireVecEnv, envs: np.ndarray) -> np.ndarray:
        """The oracle's action (P,) int8 for each aircraft of the episodes ``envs`` (P = E * N,
        env-major, as the replay stores their frames)."""
        n = env.config.n_aircraft
        labels = np.zeros((len(envs), n), np.int8)
        believed = env.believed().reshape(env.num_envs, -1)
        for row, e in enumerate(np.asarray(envs, dtype=np.int64).tolist()):
            episode = self._episode(env, e)
            d0 = int(env.decisions[e])  # a running episode: d0 < its decisions
            # A cell the team believes burning has been scored (under ideal links and disc
            # sensing nothing else makes it so); one that can still score is not.
            covered = believed[e] & (episode.future.start_step < NEVER)
            state = poses(AircraftState(*(field[e] for field in env.aircraft)), list(range(n)))
            replan_team(
                episode.future, self.config, episode.plan, state, list(range(n)), covered, d0,
                self.config.horizon, episode.rngs,
            )  # fmt: skip
            labels[row] = episode.plan[:, d0]
        return labels.reshape(-1)


Teacher = PlannerTeacher | OracleTeacher


def make_teacher(name: str, rng: np.random.Generator) -> Teacher:
    """The teacher ``--teacher name`` names (not ``none``)."""
    if name == ORACLE_POLICY:
        return OracleTeacher()
    return PlannerTeacher(name, rng)


class TeacherStats(NamedTuple):
    """The teacher's figures on one mini-batch (logged to TensorBoard)."""

    loss: float
    """The margin loss of the labelled rows (before weighting)."""
    weight: float
    """Its weight in the training loss at this iteration."""
    agreement: float
    """Fraction of the labelled rows whose greedy action is the label (NaN: none labelled)."""


def agreement(q: torch.Tensor, labels: torch.Tensor) -> float:
    """Fraction of the labelled rows of ``q`` (B, A) whose greedy action is their label."""
    labelled = labels >= 0
    if not bool(labelled.any()):
        return float("nan")
    return float((q[labelled].argmax(dim=1) == labels[labelled]).float().mean())


def margin_loss(q: torch.Tensor, labels: torch.Tensor, margin: float) -> torch.Tensor:
    """Mean large-margin loss over the labelled rows of ``q`` (B, A); 0 when none is labelled.

    ``labels`` (B,) holds an action or ``replay.NO_LABEL`` (negative)."""
    labelled = labels >= 0
    if not bool(labelled.any()):
        return q.new_zeros(())
    q, labels = q[labelled], labels[labelled]
    others = torch.ones_like(q).scatter_(1, labels[:, None], 0.0)
    best = (q + margin * others).amax(dim=1)
    return (best - q.gather(1, labels[:, None]).squeeze(1)).mean()


__all__ = [
    "OracleTeacher",
    "PlannerTeacher",
    "Teacher",
    "TeacherStats",
    "agreement",
    "make_teacher",
    "margin_loss",
]
