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

``oracle`` cannot teach this way: it plans the whole episode on its known future, tens of
seconds per episode, and would have to re-plan from every state the student visits.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch

from wildfire_agent.dynamics import AircraftState
from wildfire_agent.policy_names import PLANNER_POLICIES, planner_config
from wildfire_agent.receding_horizon import plan
from wildfire_learning.env import WildfireVecEnv
from wildfire_learning.vec_policies import flatten_aircraft, map_index, others_of


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


__all__ = ["PlannerTeacher", "TeacherStats", "agreement", "margin_loss"]
