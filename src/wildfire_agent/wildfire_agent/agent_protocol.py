"""The agent's protocol without ROS: decoded inputs in, what to publish out.

:class:`AgentProtocol` is everything the agent node decides apart from decoding and
encoding messages, so the lockstep barrier, the team state, the real-time slots and the
deadline statistics can be tested with plain calls (``tests/test_agent_protocol.py``).
Each ``on_*`` method takes one decoded, checked input (``wildfire_msgs_py.wire_checks``)
and returns the messages it makes due, in publishing order, as small value objects
(:data:`Output`); an input that must be dropped raises
:class:`~wildfire_msgs_py.input_guard.RejectedMessage`, which the node's guard counts.

Lockstep: for tick ``k`` announced by the episode status the agent waits for the fire map
of that tick's fire step, sends its visit window at ``s_k`` (from tick 1), and unless the
episode has ended waits for every peer's ``s_k`` (and, for a belief policy, the belief of
tick ``k``), decides ``a_k``, flies to ``s_{k+1}`` stamped ``(k + 1) * 0.1 s`` and
acknowledges tick ``k``: the environment's order. Inputs may arrive in any order; what a
tick has used is forgotten and later copies are refused as replays.

Real time: :meth:`AgentProtocol.on_timer` decides from the newest inputs once per 100 ms
slot; a decision that ends after its slot counts as a missed deadline.

Limited radio links: the agent also sends its radio message of each tick and decides on its
own replica and heard peers (:class:`~wildfire_agent.aircraft_radio.AircraftLinks`), never
on the aggregator's belief. In lockstep it waits for every peer's message of the tick instead
of their stamped states; in real time each slot takes a tick (:mod:`wildfire_agent.radio_ticks`)
and hears whatever has arrived and is due.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from wildfire_agent import dynamics
from wildfire_agent.agent_outputs import (
    MAX_BANK_RAD,
    AckOut,
    DeadlineOut,
    Output,
    RadioOut,
    StateOut,
    VisitOut,
    state_vector,
    team_state,
)
from wildfire_agent.aircraft_policy import AircraftPolicy
from wildfire_agent.aircraft_radio import AircraftLinks
from wildfire_agent.aircraft_sensor import AircraftSensor
from wildfire_agent.deadlines import (
    DEADLINE_EVERY_DECISIONS,
    DeadlineStats,
    next_slot_start,
)
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.radio_ticks import RadioTicks
from wildfire_msgs_py.belief_codec import belief_probability, believed_burning
from wildfire_msgs_py.belief_delta import Frame
from wildfire_msgs_py.codecs import NodeStatus, VisitWindow
from wildfire_msgs_py.contract import RADIO_STATUS
from wildfire_msgs_py.input_guard import (
    DropReason,
    RejectedMessage,
    TickInbox,
    check_status_tick,
)
from wildfire_msgs_py.radio_codec import RadioMessage
from wildfire_msgs_py.system_codecs import BeliefSnapshot, EpisodeStatus
from wildfire_sim.episode import (
    AHEAD_TICKS,
    DECISION_PERIOD_NS,
    FIRE_STEP_NS,
    REALTIME_AHEAD_NS,
    Mode,
    fire_step_tick,
    stamp_ceiling_ns,
)

REQUEST_ANSWER_PERIOD_S = 1.0
"""A belief snapshot (160 kB) goes out at most once a second, whoever asks."""
BELIEFS_KEPT = 4
"""Beliefs (and ages) held by stamp: a belief policy needs the one of its tick, no older."""


class AgentProtocol:
    """Aircraft ``k`` of ``n``: inputs by stamp, the lockstep barrier and real-time slots.

    ``now_ns`` is the node clock (stamps in real time), ``clock`` a monotonic clock in
    seconds that times the decisions.
    """

    def __init__(
        self,
        k: int,
        n: int,
        mode: Mode,
        policy: AircraftPolicy,
        start: AircraftState,
        name_tag: str,
        now_ns: Callable[[], int],
        clock: Callable[[], float] = time.monotonic,
        radio: AircraftLinks[Any] | None = None,
        sensor: AircraftSensor | None = None,
    ) -> None:
        self.sensor = sensor or AircraftSensor("disc", 0.0, 0, k)
        self.k = k
        self.n = n
        self.mode = mode
        self.policy = policy
        self.state = start
        self.name_tag = name_tag
        self.now_ns = now_ns
        self.clock = clock
        tick_ns = DECISION_PERIOD_NS if mode is Mode.LOCKSTEP else None
        self.peer_states: dict[int, TickInbox[np.ndarray]] = {
            j: TickInbox(tick_ns) for j in range(n) if j != k
        }
        self.fire: TickInbox[np.ndarray] = TickInbox(FIRE_STEP_NS)
        self.belief: TickInbox[np.ndarray] = TickInbox(tick_ns)
        self.ages: TickInbox[np.ndarray] = TickInbox(tick_ns)
        self.score = 0.0
        self.status_tick = -1
        self.final_tick: int | None = None
        self.running = False
        self.visited_tick = 0  # tick 0 has no visit: the belief starts from the ignition
        self.decided_tick = -1
        self.last_answer_s = -float("inf")
        self.stats = DeadlineStats()
        self.slot_start: float | None = None
        self.radio = radio
        self.radio_inbox: dict[int, TickInbox[tuple[RadioMessage, Any]]] = {
            j: TickInbox(tick_ns) for j in self.peer_states
        }
        self.reports: tuple[VisitWindow, ...] | None = None
        """The sensor's windows of the newest visited tick (None before the first): what the
        observation approach's camera images are made from."""
        self.received_tick = -1
        self.ready_sent = False
        self.radio_ticks = RadioTicks(self.peer_states)

    @property
    def keeps_belief(self) -> bool:
        """Whether the agent needs the shared belief (and the score).

        Belief policies decide from it (unless the links are limited: then from their own
        replica), and in real time each agent keeps a copy for an aggregator that restarts
        (lockstep runs never respawn): a lockstep agent flying another policy skips two
        100 x 100 grids per tick.
        """
        return (self.policy.needs_belief and self.radio is None) or self.mode is Mode.REALTIME

    def on_startup(self, reports_heard: bool) -> bool:
        """True once, when the node should say ready: the aggregator is known to listen to
        our reports (``reports_heard``). An orderly start: reports are durable, so one
        written before DDS matched both ends still arrives."""
        if self.ready_sent or not reports_heard:
            return False
        self.ready_sent = True
        return True

    # --- stamps -------------------------------------------------------------------------------

    def stamp(self, tick: int) -> int:
        """Stamp of tick ``tick`` in lockstep, the node clock in real time."""
        if self.mode is Mode.LOCKSTEP:
            return tick * DECISION_PERIOD_NS
        return self.now_ns()

    def ahead_limit_ns(self) -> int:
        """Newest stamp an honest input can carry now (lockstep: ticks past the status)."""
        if self.mode is Mode.LOCKSTEP:
            return self.status_ceiling_ns()
        return self.now_ns() + REALTIME_AHEAD_NS

    def status_ceiling_ns(self) -> int:
        return stamp_ceiling_ns(self.status_tick)

    # --- inputs -------------------------------------------------------------------------------

    def start(self) -> list[Output]:
        """The start pose, published once the node is up."""
        return [StateOut(self.stamp(0), state_vector(self.state), None)]

    def on_fire_map(self, stamp: int, burning: np.ndarray) -> list[Output]:
        self.fire.ceiling = self.status_ceiling_ns()  # fire maps carry the sim tick in both modes
        self.fire.accept(stamp, burning)
        if self.mode is Mode.REALTIME:
            self.fire.discard_below(stamp)  # decide from the newest map; refuse older ones
        return self.advance()

    def on_status(self, status: EpisodeStatus) -> list[Output]:
        if status.phase == "waiting":
            return []
        lockstep = self.mode is Mode.LOCKSTEP
        check_status_tick(status.tick, self.status_tick, lockstep, AHEAD_TICKS)
        self.running = True
        self.status_tick = max(self.status_tick, status.tick)
        if not lockstep:
            self.radio_ticks.on_status(status.tick, self.now_ns())
        out: list[Output] = []
        if status.final and self.final_tick is None:
            self.final_tick = status.tick
            if not lockstep:
                out += self.deadline(0, force=True)
        return out + self.advance()

    def on_peer_state(self, j: int, stamp: int, vector: np.ndarray) -> list[Output]:
        states = self.peer_states[j]
        states.ceiling = self.ahead_limit_ns()
        states.accept(stamp, vector)
        if self.mode is Mode.REALTIME:
            states.discard_below(stamp)  # the newest pose is the peer's pose
        return self.advance()

    def on_radio(self, j: int, stamp: int, message: RadioMessage) -> list[Output]:
        """Peer ``j``'s radio message (its window checked against its pose here)."""
        assert self.radio is not None  # radio messages are subscribed to under limited links
        received = (message, self.radio.payload_of(message))
        if self.mode is Mode.REALTIME:
            self.radio_ticks.take(j, message.tick)
            if self.radio.too_late(message):
                raise RejectedMessage(DropReason.STALE, f"radio tick {message.tick}: too late")
            self.radio.accept(*received)  # heard at a slot once its delay is over
            return []
        inbox = self.radio_inbox[j]
        inbox.ceiling = self.ahead_limit_ns()
        inbox.accept(stamp, received)
        return self.advance()

    def on_belief(self, stamp: int, probability: np.ndarray) -> list[Output]:
        return self._keep_belief(self.belief, stamp, probability)

    def on_ages(self, stamp: int, age_s: np.ndarray) -> list[Output]:
        return self._keep_belief(self.ages, stamp, age_s)

    def on_belief_frame(self, frame: Frame) -> list[Output]:
        """The whole shared belief of one tick (mirrored from its keyframe and delta)."""
        out = self.on_belief(frame.stamp, belief_probability(frame.grid))
        return out + self.on_ages(frame.stamp, frame.age_s)

    def _keep_belief(
        self, inbox: TickInbox[np.ndarray], stamp: int, grid: np.ndarray
    ) -> list[Output]:
        inbox.ceiling = self.ahead_limit_ns()
        inbox.accept(stamp, grid)
        inbox.keep_newest(BELIEFS_KEPT)
        return self.advance()

    def on_score(self, score: float) -> None:
        # The score is cumulative and unstamped: an older (replayed) value is smaller.
        self.score = max(self.score, score)

    def on_belief_request(self, now_s: float) -> BeliefSnapshot | None:
        """Our copy of the shared belief for a (re)started aggregator (at most once a second)."""
        common = sorted(set(self.belief.items) & set(self.ages.items))
        if not common:
            return None
        if now_s - self.last_answer_s < REQUEST_ANSWER_PERIOD_S:
            raise RejectedMessage(DropReason.RATE_LIMITED, "belief snapshot sent under 1 s ago")
        self.last_answer_s = now_s
        stamp = common[-1]
        believed = believed_burning(self.belief.items[stamp])
        return BeliefSnapshot(stamp / 1e9, self.score, believed, self.ages.items[stamp])

    # --- real time ----------------------------------------------------------------------------

    def on_timer(self, now_s: float) -> list[Output]:
        """Real time: one decision per 100 ms slot from the newest inputs (``now_s``: clock)."""
        newest_fire = self.fire.latest()
        if not self.running or self.final_tick is not None or newest_fire is None:
            return []
        if self.slot_start is None:
            self.slot_start = now_s
        late = max(0.0, now_s - self.slot_start)
        fire_stamp, burning = newest_fire
        out: list[Output] = []
        team = self.latest_team()
        belief, ages = self.latest_belief()
        if self.radio is not None:
            team, radio_out = self.radio_slot(team, burning)
            out += radio_out
            belief, ages = self.radio.belief()
        if team is None or (self.policy.needs_belief and belief is None):
            return out
        action = self.policy.decide(team, burning, fire_stamp, belief, ages, self.reports)
        flown = self.fly(action, tick=0)
        self.reports = self.visit(burning)  # at the new pose: the next decision sees them
        out += [flown, VisitOut(self.stamp(0), self.reports)]
        self.stats.add(self.clock() - now_s, late)
        out += self.deadline(0)
        self.slot_start = next_slot_start(self.slot_start, self.clock())
        return out

    def radio_slot(
        self, team: AircraftState | None, burning: np.ndarray
    ) -> tuple[AircraftState | None, list[Output]]:
        """Real time, limited links: this slot's tick, its radio message, and the team heard.

        The first slot starts the radio from the team's first poses (``team``, the stamped
        states: the mission plan); until those are in the aircraft waits.
        """
        assert self.radio is not None
        if self.radio_ticks.sent == 0:
            if team is None:
                return None, []
            self.radio.start(team)
        if self.reports is None:  # the first slot: nothing visited yet
            self.reports = self.visit(burning)
        tick = self.radio_ticks.next(self.now_ns())
        payload = self.radio.payload(self.reports)
        message = self.radio.message(tick, self.state, payload)
        self.radio.visit(tick, self.state, payload)
        self.radio.hear_due(tick)
        return self.radio.team(self.state), [RadioOut(tick * DECISION_PERIOD_NS, message)]

    def latest_team(self) -> AircraftState | None:
        peers = []
        for states in self.peer_states.values():
            newest = states.latest()
            if newest is None:
                return None
            peers.append(newest[1])
        return team_state(self.state, self.k, peers)

    def latest_belief(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        common = set(self.belief.items) & set(self.ages.items)
        if not common:
            return None, None
        stamp = max(common)
        return self.belief.items[stamp], self.ages.items[stamp]

    # --- lockstep -----------------------------------------------------------------------------

    def advance(self) -> list[Output]:
        """Lockstep: whatever the inputs received so far allow for the announced ticks."""
        out: list[Output] = []
        if self.mode is not Mode.LOCKSTEP or not self.running:
            return out
        while (tick := self.decided_tick + 1) <= self.status_tick:
            fire_stamp = fire_step_tick(tick) * DECISION_PERIOD_NS
            burning = self.fire.get(fire_stamp)
            if burning is None:
                return out
            if self.visited_tick < tick:
                windows = self.visit(burning)
                self.reports = windows
                out.append(VisitOut(self.stamp(tick), windows))
                if self.radio is not None:
                    payload = self.radio.payload(windows)
                    message = self.radio.message(tick, self.state, payload)
                    out.append(RadioOut(self.stamp(tick), message))
                self.visited_tick = tick
            if self.final_tick is not None and tick >= self.final_tick:
                self.decided_tick = tick
                return [*out, *self.deadline(tick, force=True), AckOut(self.stamp(tick))]
            stamp = tick * DECISION_PERIOD_NS
            team = self.heard_team(tick) if self.radio is not None else self.team_at(stamp)
            if team is None:
                return out
            belief = ages = None
            if self.radio is not None:
                belief, ages = self.radio.belief()
            elif self.policy.needs_belief:
                belief, ages = self.belief.get(stamp), self.ages.get(stamp)
                if belief is None or ages is None:
                    return out
            start = self.clock()
            action = self.policy.decide(team, burning, fire_stamp, belief, ages, self.reports)
            out.append(self.fly(action, tick + 1))
            self.stats.add(self.clock() - start, 0.0)
            out += self.deadline(tick + 1)
            self.forget_tick(tick)
            self.decided_tick = tick
            out.append(AckOut(self.stamp(tick)))
        return out

    def team_at(self, stamp: int) -> AircraftState | None:
        """The team at ``stamp``; None while a peer's pose of that stamp is missing."""
        peers = [states.get(stamp) for states in self.peer_states.values()]
        if any(vector is None for vector in peers):
            return None
        return team_state(self.state, self.k, [v for v in peers if v is not None])

    def heard_team(self, tick: int) -> AircraftState | None:
        """Limited links: the team as heard at ``tick``; None while a peer's tick-``tick``
        message (or, at tick 0, start pose) is missing."""
        assert self.radio is not None
        if self.received_tick < tick:
            if tick == 0:
                start = self.team_at(0)
                if start is None:
                    return None
                self.radio.start(start)
            else:
                stamp = tick * DECISION_PERIOD_NS
                peers = {j: inbox.get(stamp) for j, inbox in self.radio_inbox.items()}
                if any(received is None for received in peers.values()):
                    return None
                assert self.reports is not None
                heard = {j: received for j, received in peers.items() if received is not None}
                self.radio.receive(tick, self.state, self.radio.payload(self.reports), heard)
            self.received_tick = tick
        return self.radio.team(self.state)

    def forget_tick(self, tick: int) -> None:
        """What tick ``tick`` used is done with: later copies of it are replays."""
        for states in self.peer_states.values():
            states.discard_below((tick + 1) * DECISION_PERIOD_NS)
        for inbox in self.radio_inbox.values():
            inbox.discard_below((tick + 1) * DECISION_PERIOD_NS)
        self.fire.discard_below(fire_step_tick(tick + 1) * DECISION_PERIOD_NS)

    # --- outputs ------------------------------------------------------------------------------

    def visit(self, burning: np.ndarray) -> tuple[VisitWindow, ...]:
        """The sensor's report windows at the current pose (one decision's draws)."""
        return self.sensor.report(self.state, burning)

    def fly(self, action: int, tick: int) -> StateOut:
        self.state = dynamics.step(self.state, np.array([action], dtype=np.int64))
        bank_rad = float(self.state.bank_rad[0])
        return StateOut(self.stamp(tick), state_vector(self.state), bank_rad, int(action))

    def radio_status(self) -> NodeStatus | None:
        """The radio links' status (limited links): catch-ups and how long they took."""
        if self.radio is None:
            return None
        values = self.radio.catch_ups.summary()
        return NodeStatus(
            f"{self.name_tag}/agent: {RADIO_STATUS}",
            self.name_tag,
            "OK",
            f"{values['catch_ups']:.0f} catch-ups, longest {values['convergence_s_max']:.1f} s",
            dict(values),
        )

    def deadline(self, tick: int, force: bool = False) -> list[Output]:
        """Deadline statistics once a second of flight (every 10 decisions), and at the end."""
        if not force and self.stats.decisions % DEADLINE_EVERY_DECISIONS:
            return []
        status = self.stats.node_status(self.name_tag)
        return [DeadlineOut(self.stamp(tick), status, self.radio_status())]


__all__ = [
    "MAX_BANK_RAD",
    "AckOut",
    "AgentProtocol",
    "DeadlineOut",
    "Mode",
    "Output",
    "RadioOut",
    "StateOut",
    "VisitOut",
    "state_vector",
    "team_state",
]
