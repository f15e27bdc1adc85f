"""What an agent publishes, as small value objects (:data:`Output`), and the team's poses.

:class:`~wildfire_agent.agent_protocol.AgentProtocol` returns these; the agent node encodes
each into its messages.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from wildfire_agent import dynamics
from wildfire_agent.dynamics import AircraftState
from wildfire_msgs_py.codecs import NodeStatus, VisitWindow
from wildfire_msgs_py.radio_codec import RadioMessage

MAX_BANK_RAD = float(dynamics.MAX_BANK_STEPS * dynamics.BANK_STEP_RAD)


class StateOut(NamedTuple):
    """Own pose to publish (``state_stamped``, ``state``, ``odom``; after a decision also
    ``bank_cmd`` and ``action``)."""

    stamp: int
    vector: np.ndarray
    """x, y, heading, bank in radians (float64, 4)."""
    bank_rad: float | None
    """The commanded bank after a decision; None for the start pose."""
    action: int | None = None
    """The decision's integer action; None for the start pose."""


class VisitOut(NamedTuple):
    """What the sensor reported at the current pose: the visit window, or under camera
    sensing one window per camera."""

    stamp: int
    windows: tuple[VisitWindow, ...]


class RadioOut(NamedTuple):
    """The radio message of a tick (limited links only)."""

    stamp: int
    message: RadioMessage


class AckOut(NamedTuple):
    """Tick done: acknowledge it on ``/wildfire/ack``."""

    stamp: int


class DeadlineOut(NamedTuple):
    """Deadline statistics due on ``/diagnostics`` (the node adds its input status)."""

    stamp: int
    status: NodeStatus
    radio: NodeStatus | None = None
    """The radio links' status (limited links only)."""


Output = StateOut | VisitOut | RadioOut | AckOut | DeadlineOut


def state_vector(state: AircraftState) -> np.ndarray:
    """x, y, heading, bank (rad) of a single aircraft, as sent on ``state_stamped``."""
    return np.array(
        [state.x_m[0], state.y_m[0], state.heading_rad[0], state.bank_rad[0]], dtype=np.float64
    )


def team_state(own: AircraftState, k: int, peers: Sequence[np.ndarray]) -> AircraftState:
    """Poses of the whole team (fields (n,)): ``peers`` are the others' vectors, in order.

    Peers send their bank in radians; it is rounded back to integer 5 degree steps. The own
    bank comes from our state object (not via radians) so the decision stays bit-exact.
    """
    rows = [*peers[:k], state_vector(own), *peers[k:]]
    team = np.stack(rows)
    bank_steps = np.rint(team[:, 3] / dynamics.BANK_STEP_RAD).astype(np.int64)
    x, y, heading = team[:, 0].copy(), team[:, 1].copy(), team[:, 2].copy()
    bank_steps[k] = own.bank_steps[0]
    return AircraftState(x, y, heading, bank_steps)


__all__ = [
    "MAX_BANK_RAD",
    "AckOut",
    "DeadlineOut",
    "Output",
    "RadioOut",
    "StateOut",
    "VisitOut",
    "state_vector",
    "team_state",
]
