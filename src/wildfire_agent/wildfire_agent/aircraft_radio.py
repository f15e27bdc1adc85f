"""One aircraft's side of the radio links (no ROS): what it sends, hears and believes.

Under a limited radio model (``wildfire_belief.radio``) an agent decides on its own belief
replica and on what it heard of its peers, as the environment's :class:`Radio` does for every
aircraft at once; this class does it for aircraft ``k`` with the same functions, tick by tick:

1. at tick ``t`` (``t >= 1``) the aircraft sends :meth:`AircraftRadio.message`: its pose, the
   burning bits of the cells it visits, and the catch-up digests and replies it owes
   (``wildfire_belief.catch_up``, composed from its replica as it stands);
2. :meth:`AircraftRadio.visit` merges its own visit of tick ``t`` and keeps its position;
   :meth:`AircraftRadio.accept` takes a peer's message of any tick, in any order;
3. :meth:`AircraftRadio.hear_due` decides, for every message whose delay is over, whether it
   reaches the aircraft: with the links' draw of its send tick and the positions of both
   aircraft at that tick. Those that do are heard in the order of their send tick and
   sender: their visits, poses, digests and replies; one that ends a gap asks for a catch-up;
4. the decision reads :meth:`team` (peers heard, dead-reckoned) and :meth:`belief`.

In lockstep every peer's message of a tick is received even when the model drops it: the
model decides what the aircraft *hears*, the (reliable) middleware only carries it, so a
lockstep run flies exactly what ``wildfire eval --comm`` flies (:meth:`receive` is steps 2
and 3 for one tick). In real time the same steps run on the agent's slots: a message is
decided when the receiver has flown its send tick, so arrival order, duplicates and lateness
(up to :data:`POSITIONS_KEPT` ticks) change nothing but when it is heard.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Generic, TypeVar

import numpy as np

from wildfire_agent.dynamics import AircraftState
from wildfire_agent.heard_poses import HeardPoses
from wildfire_belief.catch_up import CatchUpQueue, link_returned, reply_keys, retry_ticks
from wildfire_belief.radio import CommModel, LinkDraws, delivered
from wildfire_belief.replicas import KEY_AIRCRAFT, BeliefReplicas, visit_key
from wildfire_belief.visits import visit_windows
from wildfire_msgs_py.codecs import VisitWindow
from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.radio_codec import (
    HEADER,
    Digest,
    RadioMessage,
    Reply,
    pack_burning,
    radio_to_bytes,
)
from wildfire_sim.grid import PAPER_MAP, MapGeometry, geometry_of

Payload = TypeVar("Payload")
"""What a radio message carries besides its pose and catch-up sections."""

POSITIONS_KEPT = 600
"""Ticks of its own positions an aircraft keeps (60 s): a message sent longer ago is too late
to decide (the delay is at most as long, ``radio.MAX_DELAY_DECISIONS``)."""


def check_replies(message: RadioMessage, geometry: MapGeometry) -> None:
    """Refuse a message whose catch-up replies name cells off the map, visits (or reports)
    of no aircraft, or ticks after the message: none of it may enter a replica."""
    for reply in message.replies:
        if reply.cells.size and int(reply.cells.max()) >= geometry.cells:
            raise RejectedMessage(DropReason.OUT_OF_RANGE, "catch-up cell off the map")
        if reply.aircraft.size and int(reply.aircraft.max()) >= KEY_AIRCRAFT:
            raise RejectedMessage(DropReason.OUT_OF_RANGE, "catch-up visit of no aircraft")
        if reply.ticks.size and int(reply.ticks.max()) > message.tick:
            raise RejectedMessage(DropReason.OUT_OF_RANGE, "catch-up visit after the message")


def window_of(message: RadioMessage, geometry: MapGeometry = PAPER_MAP) -> VisitWindow:
    """The visit window a radio message reports, checked against its pose.

    The window and its visited cells follow from the position; a message whose number of
    bits does not fit them is refused (malformed), as is a catch-up reply with cells off the map,
    visits of no aircraft or visits after the message: none of it enters a replica.
    """
    windows = visit_windows(np.array([message.x_m]), np.array([message.y_m]), geometry)
    row0, col0 = int(windows.row0[0]), int(windows.col0[0])
    visited = windows.visited[0]
    count = int(visited.sum())
    if message.bits.size != (count + 7) // 8:
        raise RejectedMessage(
            DropReason.MALFORMED, f"{message.bits.size} bytes of bits for {count} visited cells"
        )
    check_replies(message, geometry)
    burning = np.zeros_like(visited)
    burning[visited] = message.burning(count)
    return VisitWindow(row0, col0, visited, burning)


def window_cells(
    window: VisitWindow, geometry: MapGeometry = PAPER_MAP
) -> tuple[np.ndarray, np.ndarray]:
    """Flat map cells and burning values of a window's visited cells."""
    rows, cols = np.nonzero(window.visited)
    cell = (rows + window.row0) * geometry.cols + cols + window.col0
    return cell, np.asarray(window.burning, bool)[rows, cols]


class CatchUpLog:
    """What an aircraft's catch-ups took: from a link's return to the reply merged.

    A catch-up with peer ``j`` starts when a message of ``j`` ends a gap (the tick it is
    heard) and ends when ``j``'s reply is merged; its length in ticks is the replicas'
    convergence time on that link (whatever loss delays it).
    """

    def __init__(self) -> None:
        self.open: dict[int, int] = {}
        """Peer -> tick its link returned, while the reply is awaited."""
        self.done: list[tuple[int, int, int, int]] = []
        """(peer, returned tick, merged tick, cells merged) of every finished catch-up."""
        self.bytes_sent = 0

    def returned(self, peer: int, tick: int) -> None:
        self.open.setdefault(peer, tick)

    def sent(self, message: RadioMessage) -> None:
        """Count the catch-up bytes of a message (all but the header and the visit bits)."""
        self.bytes_sent += len(radio_to_bytes(message)) - HEADER.size - message.bits.size

    def merged(self, peer: int, tick: int, cells: int) -> None:
        start = self.open.pop(peer, tick)
        self.done.append((peer, start, tick, cells))

    def summary(self) -> dict[str, float]:
        """Counts and convergence times (s) for the agent's radio status."""
        ticks = [merged - start for _, start, merged, _ in self.done]
        return {
            "catch_ups": float(len(self.done)),
            "catch_ups_open": float(len(self.open)),
            "catch_up_cells": float(sum(cells for *_, cells in self.done)),
            "catch_up_bytes_sent": float(self.bytes_sent),
            "convergence_s_max": max(ticks, default=0) / 10.0,
            "convergence_s_mean": float(np.mean(ticks)) / 10.0 if ticks else 0.0,
        }


class AircraftLinks(Generic[Payload]):
    """Aircraft ``k`` of ``n`` under radio ``model`` in the episode of ``seed``: the links,
    the heard poses and the catch-up exchanges, whatever the messages' payload (the visits
    of :class:`AircraftRadio`, or the noisy reports of
    ``aircraft_report_radio.AircraftReportRadio``), which the subclass keeps and merges."""

    def __init__(self, model: CommModel, k: int, n: int, seed: int, geometry: MapGeometry) -> None:
        self.model = model
        self.k = k
        self.seed = seed
        self.geometry = geometry
        self.heard = HeardPoses(1, 1, n)
        self.draws = LinkDraws(1, n)
        self.n = n
        self.pending: list[tuple[RadioMessage, Payload]] = []
        """Messages accepted and not yet decided (their delay is not over)."""
        self.positions: dict[int, tuple[float, float]] = {}
        """Own positions by tick (the last :data:`POSITIONS_KEPT`): where the links are decided."""
        self.tick = 0
        """The last tick received."""
        self.queue = CatchUpQueue(retry_ticks(model.delay))
        self.catch_ups = CatchUpLog()

    def start(self, team: AircraftState) -> None:
        """The team's start poses (fields (n,)): the mission plan everybody knows."""
        self.heard.reset(np.array([0]), AircraftState(*(np.asarray(f)[None] for f in team)))

    def message(self, tick: int, state: AircraftState, payload: Payload) -> RadioMessage:
        """What the aircraft at ``state`` (fields (1,)) sends at ``tick`` of its ``payload``."""
        digests: tuple[Digest, ...] = ()
        replies: tuple[Reply, ...] = ()
        if self.queue.asks or self.queue.answers:
            digests, replies = self.sections(tick)
        message = RadioMessage(
            tick,
            self.k,
            float(state.x_m[0]),
            float(state.y_m[0]),
            float(state.heading_rad[0]),
            int(state.bank_steps[0]),
            self.bits(payload),
            digests,
            replies,
        )
        if digests or replies:
            self.catch_ups.sent(message)
        return message

    def receive(
        self,
        tick: int,
        state: AircraftState,
        payload: Payload,
        peers: Mapping[int, tuple[RadioMessage, Payload]],
    ) -> None:
        """Lockstep tick ``tick``: own payload, then every peer's message of the tick."""
        self.visit(tick, state, payload)
        for j in sorted(peers):
            self.accept(*peers[j])
        self.hear_due(tick)

    def visit(self, tick: int, state: AircraftState, payload: Payload) -> None:
        """The aircraft is at ``state`` (fields (1,)) at ``tick`` and sensed ``payload``."""
        self.tick = tick
        self.merge_own(tick, payload)
        self.positions[tick] = (float(state.x_m[0]), float(state.y_m[0]))
        while len(self.positions) > POSITIONS_KEPT:
            self.positions.pop(min(self.positions))

    def too_late(self, message: RadioMessage) -> bool:
        """Whether ``message`` was sent before the oldest position kept (it cannot be decided)."""
        return bool(self.positions) and message.tick < min(self.positions)

    def accept(self, message: RadioMessage, payload: Payload) -> None:
        """A peer's message (its payload checked), heard by :meth:`hear_due` if it reaches us."""
        self.pending.append((message, payload))

    def hear_due(self, tick: int) -> None:
        """Decide and hear every accepted message whose delay is over at ``tick``."""
        due = [p for p in self.pending if p[0].tick + self.model.delay <= tick]
        if due:
            self.pending = [p for p in self.pending if p[0].tick + self.model.delay > tick]
            for message, payload in sorted(due, key=lambda p: (p[0].tick, p[0].aircraft)):
                if self.reaches(message):
                    self._hear(tick, message, payload)
        self.settle()

    def reaches(self, message: RadioMessage) -> bool:
        """The radio model's verdict on ``message``: both positions at its send tick (ours: the
        newest kept at or before it) and the link's draw of that tick."""
        sent = message.tick
        own = max((t for t in self.positions if t <= sent), default=min(self.positions))
        x, y = np.zeros((1, self.n)), np.zeros((1, self.n))
        x[0, message.aircraft], y[0, message.aircraft] = message.x_m, message.y_m
        x[0, self.k], y[0, self.k] = self.positions[own]
        draws = self.draws.at(np.array([self.seed]), np.array([sent]))
        reach = delivered(self.model, draws, x, y, np.array([sent]))
        return bool(reach[0, message.aircraft, self.k])

    def _hear(self, tick: int, message: RadioMessage, payload: Payload) -> None:
        self.merge_heard(message, payload)
        j = message.aircraft
        returned = bool(link_returned(self.heard.tick[0, 0, j], message.tick))
        if returned:
            self.catch_ups.returned(j, tick)
        self.queue.on_heard(j, tick, returned)
        for digest in message.digests:
            if digest.target == self.k:
                self.queue.on_digest(j, digest.block_ticks)
        for reply in message.replies:
            if reply.target == self.k:
                self.queue.on_reply(j)
                self.merge_reply(reply)
                self.catch_ups.merged(j, tick, reply.cells.size)
        pose = AircraftState(
            np.array([message.x_m]),
            np.array([message.y_m]),
            np.array([message.heading_rad]),
            np.array([message.bank_steps], dtype=np.int64),
        )
        zero, sender = np.zeros(1, dtype=np.int64), np.array([message.aircraft])
        self.heard.hear(zero, zero, sender, np.array([message.tick]), pose)

    def team(self, state: AircraftState) -> AircraftState:
        """The team the aircraft at ``state`` (fields (1,)) decides on now, fields (n,)."""
        own = AircraftState(*(np.asarray(f)[None] for f in state))  # (1, 1)
        team = self.heard.team(np.array([self.tick]), own, np.array([self.k]))
        return AircraftState(*(f[0, 0] for f in team))

    # The payload's side, in the subclass.
    def payload(self, reports: tuple[VisitWindow, ...]) -> Payload:
        """The payload of one tick's sensor windows (``AircraftSensor.report``)."""
        raise NotImplementedError

    def payload_of(self, message: RadioMessage) -> Payload:
        """A peer's message's payload, checked against its pose (RejectedMessage if not)."""
        raise NotImplementedError

    def bits(self, payload: Payload) -> np.ndarray:
        raise NotImplementedError

    def sections(self, tick: int) -> tuple[tuple[Digest, ...], tuple[Reply, ...]]:
        raise NotImplementedError

    def merge_own(self, tick: int, payload: Payload) -> None:
        raise NotImplementedError

    def merge_heard(self, message: RadioMessage, payload: Payload) -> None:
        raise NotImplementedError

    def merge_reply(self, reply: Reply) -> None:
        raise NotImplementedError

    def settle(self) -> None:
        """After a tick's messages: nothing to do for visits (merged as they come)."""

    def belief(self) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError


class AircraftRadio(AircraftLinks[VisitWindow]):
    """Aircraft ``k`` of ``n`` under radio ``model`` in the episode of ``seed``, with the
    paper's perfect disc: the messages carry visits, merged into a binary replica."""

    def __init__(self, model: CommModel, k: int, n: int, seed: int, ignition: np.ndarray) -> None:
        super().__init__(model, k, n, seed, geometry_of(np.asarray(ignition)))
        self.replica = BeliefReplicas(1, 1, self.geometry)
        self.replica.reset([0], np.asarray(ignition, bool)[None])

    def payload(self, reports: tuple[VisitWindow, ...]) -> VisitWindow:
        return reports[0]  # the disc's one window

    def payload_of(self, message: RadioMessage) -> VisitWindow:
        return window_of(message, self.geometry)

    def bits(self, payload: VisitWindow) -> np.ndarray:
        return pack_burning(np.asarray(payload.burning, bool)[np.asarray(payload.visited, bool)])

    def sections(self, tick: int) -> tuple[tuple[Digest, ...], tuple[Reply, ...]]:
        return self.queue.compose(tick, self.replica.key[0, 0], self.replica.burning[0, 0])

    def merge_own(self, tick: int, payload: VisitWindow) -> None:
        self.replica.now[0] = tick
        self._merge(payload, tick, self.k)

    def merge_heard(self, message: RadioMessage, payload: VisitWindow) -> None:
        self._merge(payload, message.tick, message.aircraft)

    def merge_reply(self, reply: Reply) -> None:
        zero = np.zeros(reply.cells.size, dtype=np.int64)
        cells = reply.cells.astype(np.int64)
        self.replica.merge(zero, zero, cells, reply_keys(reply), reply.burning)

    def _merge(self, window: VisitWindow, tick: int, aircraft: int) -> None:
        cell, burning = window_cells(window, self.geometry)
        zero = np.zeros(cell.size, dtype=np.int64)
        self.replica.merge(zero, zero, cell, np.full(cell.size, visit_key(tick, aircraft)), burning)

    def belief(self) -> tuple[np.ndarray, np.ndarray]:
        """The replica: believed burning (H, W) bool and ages (H, W) float32 seconds."""
        return self.replica.burning[0, 0], self.replica.age_s()[0, 0]


__all__ = [
    "POSITIONS_KEPT",
    "AircraftLinks",
    "AircraftRadio",
    "CatchUpLog",
    "check_replies",
    "window_cells",
    "window_of",
]
