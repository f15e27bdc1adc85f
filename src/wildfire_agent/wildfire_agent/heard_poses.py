"""What each aircraft knows of its peers' poses: the last it heard, dead-reckoned.

Under limited radio links (``wildfire_belief.radio``) a peer's pose arrives with its radio
message, late or not at all. Each aircraft keeps the newest pose it heard of every peer
with the tick it was sent, and between messages assumes the peer holds its bank: the pose
is flown forward at constant bank to the current tick (:func:`coast`). Before take-off the
team knows every start pose (the mission plan), so nobody is ever unknown.

The environment keeps one table per aircraft; an agent node keeps its own. Both build the
team they decide on with :meth:`HeardPoses.team`, so they decide on the same poses.
"""

from __future__ import annotations

import numpy as np

from wildfire_agent.dynamics import DECISION_PERIOD_S, AircraftState, propagate


def coast(state: AircraftState, decisions: np.ndarray) -> AircraftState:
    """Poses after ``decisions`` decisions at constant bank (same shape as the fields).

    One exact arc of ``decisions * 0.1 s`` (not step by step: a prediction need not match
    the stepped floats, only be the same wherever it is made); zero decisions leave the
    pose as it is, bit for bit.
    """
    decisions = np.asarray(decisions, dtype=np.int64)
    flown = propagate(state, decisions * DECISION_PERIOD_S)
    return AircraftState(
        *(np.where(decisions == 0, now, later) for now, later in zip(state, flown, strict=True))
    )


class HeardPoses:
    """The poses ``R`` receivers heard of ``N`` aircraft in each of ``E`` environments.

    ``pose`` fields are (E, R, N) and ``tick`` (E, R, N) the tick each pose was sent at.
    """

    def __init__(self, num_envs: int, receivers: int, n: int) -> None:
        shape = (num_envs, receivers, n)
        self.pose = AircraftState(
            np.zeros(shape), np.zeros(shape), np.zeros(shape), np.zeros(shape, dtype=np.int64)
        )
        self.tick = np.zeros(shape, dtype=np.int64)

    def reset(self, env_ids: np.ndarray, start: AircraftState) -> None:
        """Every receiver of ``env_ids`` knows the start poses ``start`` (fields (k, N))."""
        for heard, given in zip(self.pose, start, strict=True):
            heard[env_ids] = np.asarray(given)[:, None, :]
        self.tick[env_ids] = 0

    def hear(
        self,
        env: np.ndarray,
        receiver: np.ndarray,
        sender: np.ndarray,
        tick: np.ndarray,
        pose: AircraftState,
    ) -> None:
        """Messages heard (flat arrays; ``pose`` fields flat too): newer ones replace older."""
        newer = tick > self.tick[env, receiver, sender]
        index = (env[newer], receiver[newer], sender[newer])
        for heard, given in zip(self.pose, pose, strict=True):
            heard[index] = np.asarray(given)[newer]
        self.tick[index] = tick[newer]

    def team(self, now: np.ndarray, own: AircraftState, own_index: np.ndarray) -> AircraftState:
        """The team each receiver decides on at tick ``now`` (E,), fields (E, R, N).

        Peers are their heard poses coasted to ``now``; receiver ``r`` is aircraft
        ``own_index[r]`` and sees itself exactly (``own`` fields (E, R)).
        """
        team = coast(self.pose, np.asarray(now)[:, None, None] - self.tick)
        receivers = np.arange(len(own_index))
        for field, own_field in zip(team, own, strict=True):
            field[:, receivers, own_index] = own_field
        return team


__all__ = ["HeardPoses", "coast"]
