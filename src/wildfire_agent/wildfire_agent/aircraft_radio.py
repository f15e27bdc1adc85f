"""One aircraft's side of the radio links (no ROS): what it sends, hears and believes.

Under a limited radio model (``wildfire_belief.radio``) an agent decides on its own belief
replica and on what it heard of its peers, as the environment's :class:`Radio` does for every
aircraft at once; this class does it for aircraft ``k`` with the same functions, tick by tick:

1. at tick ``t`` (``t >= 1``) the aircraft sends :meth:`AircraftRadio.message`: its pose and
   the burning bits of the cells it visits;
2. once every peer's message of tick ``t`` is in, :meth:`AircraftRadio.receive` merges its own
   visit, decides with the links' draws of tick ``t`` which peer messages reach it (from the
   positions at ``t``), holds those for ``delay`` ticks, and merges the ones due now;
3. the decision reads :meth:`team` (peers heard, dead-reckoned) and :meth:`belief`.

Every peer's message of a tick is received even when the model drops it: the model decides
what the aircraft *hears*, the (reliable) middleware only carries it, so a lockstep run
flies exactly what ``wildfire eval --comm`` flies.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from wildfire_agent.dynamics import AircraftState
from wildfire_agent.heard_poses import HeardPoses
from wildfire_belief.radio import CommModel, LinkDraws, delivered
from wildfire_belief.replicas import BeliefReplicas, visit_key
from wildfire_belief.visits import visit_windows
from wildfire_msgs_py.codecs import VisitWindow
from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.radio_codec import RadioMessage, pack_burning
from wildfire_sim.grid import GRID_SIZE


def window_of(message: RadioMessage) -> VisitWindow:
    """The visit window a radio message reports, checked against its pose.

    The visited cells follow from the position; a message whose origin or number of bits
    does not fit them is refused (malformed), so it never enters a replica.
    """
    windows = visit_windows(np.array([message.x_m]), np.array([message.y_m]))
    row0, col0 = int(windows.row0[0]), int(windows.col0[0])
    visited = windows.visited[0]
    if (message.row0, message.col0) != (row0, col0):
        raise RejectedMessage(
            DropReason.MALFORMED,
            f"window origin ({message.row0}, {message.col0}) does not fit the pose ({row0}, "
            f"{col0})",
        )
    count = int(visited.sum())
    if message.bits.size != (count + 7) // 8:
        raise RejectedMessage(
            DropReason.MALFORMED, f"{message.bits.size} bytes of bits for {count} visited cells"
        )
    burning = np.zeros_like(visited)
    burning[visited] = message.burning(count)
    return VisitWindow(row0, col0, visited, burning)


def window_cells(window: VisitWindow) -> tuple[np.ndarray, np.ndarray]:
    """Flat map cells and burning values of a window's visited cells."""
    rows, cols = np.nonzero(window.visited)
    cell = (rows + window.row0) * GRID_SIZE + cols + window.col0
    return cell, np.asarray(window.burning, bool)[rows, cols]


class AircraftRadio:
    """Aircraft ``k`` of ``n`` under radio ``model`` in the episode of ``seed``."""

    def __init__(self, model: CommModel, k: int, n: int, seed: int, ignition: np.ndarray) -> None:
        self.model = model
        self.k = k
        self.seed = seed
        self.replica = BeliefReplicas(1, 1)
        self.replica.reset([0], np.asarray(ignition, bool)[None])
        self.heard = HeardPoses(1, 1, n)
        self.draws = LinkDraws(1, n)
        self.in_flight: dict[int, list[tuple[RadioMessage, VisitWindow]]] = {}
        """Messages that will be heard, by the tick they are heard at."""
        self.tick = 0
        """The last tick received."""

    def start(self, team: AircraftState) -> None:
        """The team's start poses (fields (n,)): the mission plan everybody knows."""
        self.heard.reset(np.array([0]), AircraftState(*(np.asarray(f)[None] for f in team)))

    def message(self, tick: int, state: AircraftState, window: VisitWindow) -> RadioMessage:
        """What the aircraft at ``state`` (fields (1,)) sends at ``tick`` of its ``window``."""
        return RadioMessage(
            tick,
            self.k,
            float(state.x_m[0]),
            float(state.y_m[0]),
            float(state.heading_rad[0]),
            int(state.bank_steps[0]),
            window.row0,
            window.col0,
            pack_burning(np.asarray(window.burning, bool)[np.asarray(window.visited, bool)]),
        )

    def receive(
        self,
        tick: int,
        state: AircraftState,
        window: VisitWindow,
        peers: Mapping[int, tuple[RadioMessage, VisitWindow]],
    ) -> None:
        """Tick ``tick``: own visit, then every peer's message of the tick (checked windows)."""
        self.tick = tick
        self.replica.now[0] = tick
        self._merge(window, tick, self.k)
        team = {j: (m.x_m, m.y_m) for j, (m, _) in peers.items()}
        team[self.k] = (float(state.x_m[0]), float(state.y_m[0]))
        order = sorted(team)
        x = np.array([[team[j][0] for j in order]])
        y = np.array([[team[j][1] for j in order]])
        reach = delivered(self.model, self.draws.at(np.array([self.seed]), np.array([tick])), x, y)
        for j, received in peers.items():
            if reach[0, j, self.k]:
                self.in_flight.setdefault(tick + self.model.delay, []).append(received)
        for message, heard_window in self.in_flight.pop(tick, []):
            self._merge(heard_window, message.tick, message.aircraft)
            pose = AircraftState(
                np.array([message.x_m]),
                np.array([message.y_m]),
                np.array([message.heading_rad]),
                np.array([message.bank_steps], dtype=np.int64),
            )
            zero, sender = np.zeros(1, dtype=np.int64), np.array([message.aircraft])
            self.heard.hear(zero, zero, sender, np.array([message.tick]), pose)

    def _merge(self, window: VisitWindow, tick: int, aircraft: int) -> None:
        cell, burning = window_cells(window)
        zero = np.zeros(cell.size, dtype=np.int64)
        self.replica.merge(zero, zero, cell, np.full(cell.size, visit_key(tick, aircraft)), burning)

    def team(self, state: AircraftState) -> AircraftState:
        """The team the aircraft at ``state`` (fields (1,)) decides on now, fields (n,)."""
        own = AircraftState(*(np.asarray(f)[None] for f in state))  # (1, 1)
        team = self.heard.team(np.array([self.tick]), own, np.array([self.k]))
        return AircraftState(*(f[0, 0] for f in team))

    def belief(self) -> tuple[np.ndarray, np.ndarray]:
        """The replica: believed burning (H, W) bool and ages (H, W) float32 seconds."""
        return self.replica.burning[0, 0], self.replica.age_s()[0, 0]


__all__ = ["AircraftRadio", "window_cells", "window_of"]
