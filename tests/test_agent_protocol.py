"""The agent's protocol without DDS: plain calls in, value objects out.

A lockstep team of protocols whose outputs are routed to each other by hand must fly
exactly what ``wildfire_agent.dynamics`` flies for the same actions, whatever order the
inputs arrive in; replays and duplicates are refused (the first message counts), a peer
that vanishes stalls the barrier without an error, and real-time slots count missed
deadlines from an injected clock.
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pytest

from wildfire_agent import dynamics
from wildfire_agent.agent_protocol import (
    AckOut,
    AgentProtocol,
    DeadlineOut,
    Mode,
    Output,
    StateOut,
    VisitOut,
    state_vector,
    team_state,
)
from wildfire_agent.aircraft_policy import AircraftPolicy
from wildfire_agent.deadlines import PERIOD_S, DeadlineStats, next_slot_start
from wildfire_agent.dynamics import AircraftState
from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.system_codecs import EpisodeStatus
from wildfire_sim.episode import DECISION_PERIOD_NS, DECISIONS_PER_FIRE_STEP, initial_fire

SEED = 5
TICK = DECISION_PERIOD_NS
BURNING = initial_fire(SEED, "circular").burning[0]


def start_state(n: int) -> AircraftState:
    return AircraftState(
        x_m=np.linspace(400.0, 600.0, n),
        y_m=np.linspace(450.0, 520.0, n),
        heading_rad=np.linspace(-1.0, 2.0, n),
        bank_steps=np.arange(n, dtype=np.int64) - 1,
    )


def own_start(team: AircraftState, k: int) -> AircraftState:
    return AircraftState(*(np.array(field[k : k + 1], copy=True) for field in team))


def status(tick: int, phase: str = "running") -> EpisodeStatus:
    return EpisodeStatus(phase, {"tick": str(tick)})


class FakeClock:
    """A monotonic clock the test sets (seconds) and a node clock (ns) that follows it."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def ns(self) -> int:
        return round(self.now * 1e9)


def make_protocol(
    k: int, n: int, mode: Mode = Mode.LOCKSTEP, policy: str = "random", clock: Any = None
) -> AgentProtocol:
    clock = clock or FakeClock()
    return AgentProtocol(
        k,
        n,
        mode,
        AircraftPolicy(policy, k, n, SEED),
        own_start(start_state(n), k),
        f"uav{k}",
        clock.ns,
        clock,
    )


def refused(call: Any, *args: Any) -> DropReason:
    with pytest.raises(RejectedMessage) as error:
        call(*args)
    return error.value.reason


class Team:
    """Protocols of a whole team; states one publishes are delivered to the others."""

    def __init__(self, n: int) -> None:
        self.agents = [make_protocol(k, n) for k in range(n)]
        self.sent: list[list[Output]] = [[] for _ in range(n)]
        self.queue: deque[tuple[int, Output]] = deque()

    def deliver(self, sender: int, outputs: list[Output]) -> None:
        self.queue.extend((sender, out) for out in outputs)
        while self.queue:
            k, out = self.queue.popleft()
            self.sent[k].append(out)
            if isinstance(out, StateOut):
                for j, agent in enumerate(self.agents):
                    if j != k:
                        self.queue.extend(
                            (j, o) for o in agent.on_peer_state(k, out.stamp, out.vector)
                        )

    def broadcast(self, event: str, *args: Any) -> None:
        for k, agent in enumerate(self.agents):
            self.deliver(k, getattr(agent, event)(*args))


def reference(n: int, ticks: int) -> list[AircraftState]:
    """States s_1..s_ticks flown by ``dynamics.step`` with the pilots' own random streams."""
    return reference_flight(n, ticks)[0]


def reference_flight(n: int, ticks: int) -> tuple[list[AircraftState], list[np.ndarray]]:
    """States s_1..s_ticks and the (n,) actions a_0..a_{ticks-1} that flew them."""
    pilots = [AircraftPolicy("random", k, n, SEED) for k in range(n)]
    state = start_state(n)
    states, actions = [], []
    for _ in range(ticks):
        action = np.array([p.decide(state, BURNING) for p in pilots], dtype=np.int64)
        state = dynamics.step(state, action)
        states.append(state)
        actions.append(action)
    return states, actions


def run_in_order(team: Team, ticks: int) -> None:
    for agent_k, agent in enumerate(team.agents):
        team.deliver(agent_k, agent.start())
    for tick in range(ticks + 1):
        if tick % DECISIONS_PER_FIRE_STEP == 0:
            team.broadcast("on_fire_map", tick * TICK, BURNING)
        team.broadcast("on_status", status(tick, "truncated" if tick == ticks else "running"))


def test_in_order_lockstep_equals_dynamics() -> None:
    n, ticks = 3, 30  # crosses the fire step of tick 25
    team = Team(n)
    run_in_order(team, ticks)
    flown, actions = reference_flight(n, ticks)
    expected = flown[-1]
    for k, agent in enumerate(team.agents):
        # Every decision publishes its integer action (the start pose has none).
        published = [out.action for out in team.sent[k] if isinstance(out, StateOut)]
        assert published == [None] + [int(a[k]) for a in actions]
        assert agent.state.x_m[0] == expected.x_m[k]
        assert agent.state.y_m[0] == expected.y_m[k]
        assert agent.state.heading_rad[0] == expected.heading_rad[k]
        assert agent.state.bank_steps[0] == expected.bank_steps[k]
        acks = [out.stamp for out in team.sent[k] if isinstance(out, AckOut)]
        assert acks == [tick * TICK for tick in range(ticks + 1)]
        visits = [out.stamp for out in team.sent[k] if isinstance(out, VisitOut)]
        assert visits == [tick * TICK for tick in range(1, ticks + 1)]  # none at tick 0
        deadlines = [out for out in team.sent[k] if isinstance(out, DeadlineOut)]
        assert [d.stamp for d in deadlines] == [10 * TICK, 20 * TICK, 30 * TICK, 30 * TICK]
        assert deadlines[-1].status.values["decisions"] == ticks
        assert agent.stats.decisions == ticks


def test_out_of_order_inputs_give_the_same_flight() -> None:
    """Peer state before the status, fire map after it: the barrier waits, then catches up."""
    expected = reference(2, 2)
    agent = make_protocol(0, 2)
    peer = own_start(start_state(2), 1)
    assert agent.on_peer_state(1, 0, state_vector(peer)) == []
    assert agent.on_status(status(0)) == []
    out = agent.on_fire_map(0, BURNING)
    assert [type(o) for o in out] == [StateOut, AckOut] and out[1].stamp == 0
    out = agent.on_status(status(1))  # the visit of s_1; the peer's s_1 is missing
    assert [type(o) for o in out] == [VisitOut] and out[0].stamp == TICK
    peer1 = AircraftState(*(field[1:2] for field in expected[0]))
    out = agent.on_peer_state(1, TICK, state_vector(peer1))
    # Now the decision of tick 1: state s_2 and the ack.
    assert [type(o) for o in out] == [StateOut, AckOut]
    assert agent.state.x_m[0] == expected[1].x_m[0]
    assert agent.state.bank_steps[0] == expected[1].bank_steps[0]


def test_late_inputs_release_every_waiting_tick_in_order() -> None:
    agent = make_protocol(0, 2)
    agent.on_fire_map(0, BURNING)
    agent.on_status(status(0))
    peer = start_state(2)
    assert agent.on_status(status(1)) == []
    out = agent.on_peer_state(1, 0, state_vector(own_start(peer, 1)))
    # s_1, the ack of tick 0, the visit at s_1; tick 1 waits for the peer's s_1.
    assert [type(o) for o in out] == [StateOut, AckOut, VisitOut]
    out = agent.on_peer_state(1, TICK, state_vector(own_start(peer, 1)))
    assert [o.stamp for o in out if isinstance(o, AckOut)] == [TICK]
    assert agent.decided_tick == 1


def test_duplicates_and_replays_are_refused_and_the_first_counts() -> None:
    agent = make_protocol(0, 2)
    peer = own_start(start_state(2), 1)
    first, second = state_vector(peer), state_vector(peer) + np.array([50.0, 0.0, 0.0, 0.0])
    agent.on_peer_state(1, 0, first)
    assert refused(agent.on_peer_state, 1, 0, second) is DropReason.DUPLICATE
    assert agent.peer_states[1].get(0) is first
    agent.on_fire_map(0, BURNING)
    assert refused(agent.on_fire_map, 0, ~BURNING) is DropReason.DUPLICATE
    agent.on_status(status(0))
    assert agent.decided_tick == 0
    assert refused(agent.on_peer_state, 1, 0, first) is DropReason.STALE  # tick 0 is used
    assert refused(agent.on_peer_state, 1, 0, second) is DropReason.STALE
    assert refused(agent.on_status, status(5)) is DropReason.FUTURE  # lockstep skips no tick
    agent.on_status(status(0))  # a replayed status is harmless
    assert refused(agent.on_peer_state, 1, 60 * TICK, first) is DropReason.FUTURE
    assert refused(agent.on_peer_state, 1, 3 * TICK // 2, first) is DropReason.OUT_OF_RANGE
    assert refused(agent.on_fire_map, 100 * TICK, BURNING) is DropReason.FUTURE
    assert agent.decided_tick == 0


def test_a_vanished_peer_stalls_the_barrier_without_error() -> None:
    agent = make_protocol(0, 3)
    agent.on_fire_map(0, BURNING)
    team = start_state(3)
    agent.on_peer_state(1, 0, state_vector(own_start(team, 1)))
    agent.on_peer_state(2, 0, state_vector(own_start(team, 2)))
    agent.on_status(status(0))
    assert agent.decided_tick == 0
    agent.on_peer_state(1, TICK, state_vector(own_start(team, 1)))  # uav2 is gone
    for tick in (1, 2, 3):
        out = agent.on_status(status(tick))
        assert not any(isinstance(o, (StateOut, AckOut)) for o in out)
    assert agent.decided_tick == 0 and agent.stats.decisions == 1


def test_team_state_rounds_the_peers_bank_to_steps() -> None:
    own = own_start(start_state(3), 1)
    noisy = np.array([1.0, 2.0, 0.5, 3 * dynamics.BANK_STEP_RAD + 1e-9])
    team = team_state(own, 1, [noisy, noisy])
    assert team.bank_steps.tolist() == [3, int(own.bank_steps[0]), 3]
    assert team.x_m.tolist() == [1.0, own.x_m[0], 1.0]
    assert team.bank_steps.dtype == np.int64


def test_slots_follow_the_wall_clock() -> None:
    assert next_slot_start(1.0, 1.05) == pytest.approx(1.1)
    assert next_slot_start(1.0, 1.35) == pytest.approx(1.3)  # overran: skipped slots
    stats = DeadlineStats()
    stats.add(0.05, 0.0)
    stats.add(0.05, 0.06)  # late start: missed
    stats.add(PERIOD_S + 0.001, 0.0)
    assert (stats.decisions, stats.missed) == (3, 2)
    assert stats.level() == "ERROR"


def test_realtime_timer_decides_once_per_slot_and_counts_missed_deadlines() -> None:
    clock = FakeClock()
    agent = make_protocol(0, 2, Mode.REALTIME, clock=clock)
    assert agent.on_timer(0.0) == []  # nothing received yet
    clock.now = 1.0
    agent.on_status(status(10))
    agent.on_fire_map(0, BURNING)
    assert agent.on_timer(1.0) == []  # the peer's pose is missing
    agent.on_peer_state(1, clock.ns(), state_vector(own_start(start_state(2), 1)))
    assert refused(agent.on_peer_state, 1, clock.ns() - 1, np.zeros(4)) is DropReason.STALE
    for i in range(10):
        start = 1.0 + i * PERIOD_S
        clock.now = start + (0.15 if i == 3 else 0.02)  # decision 3 overruns its slot
        out = agent.on_timer(start)
        assert [type(o) for o in out][:2] == [StateOut, VisitOut]
    assert (agent.stats.decisions, agent.stats.missed) == (10, 1)
    assert isinstance(out[-1], DeadlineOut)  # the 10th decision: statistics due
    assert out[-1].status.level == "ERROR"
    final = agent.on_status(status(25, "terminated"))
    assert [type(o) for o in final] == [DeadlineOut]
    assert agent.on_timer(3.0) == []  # no decisions after the end


def test_belief_request_is_rate_limited() -> None:
    agent = make_protocol(0, 2, Mode.REALTIME)
    assert agent.keeps_belief
    assert agent.on_belief_request(0.0) is None  # no belief yet: nothing to send
    agent.on_belief(0, BURNING)
    agent.on_ages(0, np.zeros(BURNING.shape, dtype=np.float32))
    agent.on_score(12.0)
    agent.on_score(3.0)  # a replayed (older) cumulative score
    snapshot = agent.on_belief_request(5.0)
    assert snapshot is not None and snapshot.score == 12.0
    assert refused(agent.on_belief_request, 5.5) is DropReason.RATE_LIMITED
    assert agent.on_belief_request(6.0) is not None
