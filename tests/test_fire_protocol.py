"""The fire simulator's protocol without DDS: acknowledgements in, ticks out.

Tick 0 waits for every reporter's ready; tick ``k + 1`` for every acknowledgement of ``k``,
in any order; acknowledgements of unannounced or already acknowledged ticks are refused; a
reporter that vanishes stalls the episode without error; the run ends ``complete``; and the
episode it paces equals a :class:`~wildfire_sim.episode.FireEpisode` advanced directly.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.system_codecs import READY_SUFFIX
from wildfire_sim.episode import (
    DECISION_PERIOD_NS,
    DECISIONS_PER_FIRE_STEP,
    FireEpisode,
    Mode,
)
from wildfire_sim.fire_protocol import (
    ClockOut,
    DiagnosticsOut,
    FireProtocol,
    LogOut,
    MapsOut,
    StatusOut,
)

TICK = DECISION_PERIOD_NS
REPORTERS = ("uav0", "uav1", "belief_aggregator")


def episode(decisions: int = 30) -> FireEpisode:
    return FireEpisode(4, "circular", (0.2, 0.0), max_decisions=decisions, preburn_steps=0)


def refused(call: Any, *args: Any) -> DropReason:
    with pytest.raises(RejectedMessage) as error:
        call(*args)
    return error.value.reason


def ready(protocol: FireProtocol) -> list[Any]:
    out: list[Any] = []
    for reporter in REPORTERS:
        out = protocol.on_ack(reporter + READY_SUFFIX, 0)
    return out


def test_start_waits_for_every_ready_then_announces_tick_0() -> None:
    protocol = FireProtocol(episode(), Mode.LOCKSTEP, REPORTERS)
    assert [type(o) for o in protocol.start()] == [MapsOut, StatusOut]
    assert protocol.start()[1] == StatusOut("waiting", -1)
    assert refused(protocol.on_ack, "uav0", 0) is DropReason.FUTURE  # not started
    assert protocol.on_ack("uav0" + READY_SUFFIX, 0) == []
    assert protocol.on_ack("uav1" + READY_SUFFIX, 0) == []
    out = protocol.on_ack("belief_aggregator" + READY_SUFFIX, 0)
    assert [type(o) for o in out] == [LogOut, StatusOut, ClockOut, DiagnosticsOut]
    assert out[1] == StatusOut("running", 0) and out[2] == ClockOut(0)


def test_lockstep_barrier_runs_the_episode_to_complete() -> None:
    protocol = FireProtocol(episode(30), Mode.LOCKSTEP, REPORTERS)
    reference = episode(30)
    ready(protocol)
    for tick in range(30):
        stamp = tick * TICK
        assert protocol.on_ack("uav1", stamp) == []
        assert protocol.on_ack("belief_aggregator", stamp) == []
        out = protocol.on_ack("uav0", stamp)  # the last one releases the next tick
        stepped = reference.advance()
        kinds = [type(o) for o in out]
        assert (MapsOut in kinds) == stepped == ((tick + 1) % DECISIONS_PER_FIRE_STEP == 0)
        status = next(o for o in out if isinstance(o, StatusOut))
        assert status == StatusOut(reference.phase, tick + 1)
        assert ClockOut((tick + 1) * TICK) in out
    assert np.array_equal(protocol.episode.burning, reference.burning)
    assert not protocol.complete
    for reporter in REPORTERS:
        out = protocol.on_ack(reporter, 30 * TICK)
    assert protocol.complete and out[0] == StatusOut("truncated", 30, complete=True)
    assert isinstance(out[1], DiagnosticsOut) and out[1].status.values["complete"] == 1


def test_future_and_replayed_acks_are_refused_and_a_vanished_reporter_stalls() -> None:
    protocol = FireProtocol(episode(), Mode.LOCKSTEP, REPORTERS)
    ready(protocol)
    protocol.on_ack("uav0", 0)
    assert refused(protocol.on_ack, "uav0", 0) is DropReason.STALE
    assert refused(protocol.on_ack, "uav1", TICK) is DropReason.FUTURE
    protocol.on_ack("uav1", 0)  # belief_aggregator never answers
    assert protocol.episode.decisions == 0 and protocol.on_ack("uav1" + READY_SUFFIX, 0) == []


def test_maps_are_copies_of_the_fire_step() -> None:
    protocol = FireProtocol(episode(), Mode.REALTIME, REPORTERS)
    maps = protocol.start()[0]
    assert isinstance(maps, MapsOut)
    before = maps.burning.copy()
    ready(protocol)
    for _ in range(DECISIONS_PER_FIRE_STEP):
        protocol.on_timer()
    assert not np.array_equal(protocol.episode.burning, before)
    assert np.array_equal(maps.burning, before)


def test_realtime_timer_announces_fire_steps_and_the_end() -> None:
    protocol = FireProtocol(episode(30), Mode.REALTIME, REPORTERS)
    assert protocol.on_timer() == []  # not started
    out = ready(protocol)
    assert ClockOut(0) not in out  # no /clock in real time
    announced = []
    while not protocol.complete:
        out = protocol.on_timer()
        announced += [o for o in out if isinstance(o, StatusOut)]
    assert announced == [
        StatusOut("running", 25),
        StatusOut("truncated", 30),
        StatusOut("truncated", 30, complete=True),
    ]
    assert protocol.on_timer() == []


def test_the_tick_split_says_where_each_ticks_wall_time_went() -> None:
    """On a scripted clock: each tick, the agents answer 3 and 5 ms after the announcement,
    the monitor 4 ms and the aggregator 9 ms; the barrier's own part follows the last."""
    times = [0.0]  # tick 0's announcement
    reporters = (*REPORTERS, "wildfire_run")
    order = [("uav0", 3), ("wildfire_run", 4), ("uav1", 5), ("belief_aggregator", 9)]
    for _ in range(7):
        start = times[-1]
        times += [start + lag / 1e3 for _, lag in order]
        times.append(times[-1] + 0.002)  # the next announcement (or the end), 2 ms on
    clock = iter(times)
    protocol = FireProtocol(episode(6), Mode.LOCKSTEP, reporters, clock=lambda: next(clock))
    protocol.start()
    for reporter in reporters:
        out = protocol.on_ack(reporter + READY_SUFFIX, 0)
    for tick in range(7):
        for reporter, _ in order:
            out = protocol.on_ack(reporter, tick * TICK)
    assert protocol.complete and next(clock, None) is None  # every time taken, in order
    values = out[1].status.values if isinstance(out[1], DiagnosticsOut) else {}
    assert values["split_ticks"] == 7
    assert values["split_nodes_ms"] == pytest.approx(9.0)
    assert values["split_fire_ms"] == pytest.approx(2.0)
    assert values["split_agents_ms"] == pytest.approx(5.0)  # the slower of the two
    assert values["split_belief_aggregator_ms"] == pytest.approx(9.0)
    assert values["split_wildfire_run_ms"] == pytest.approx(4.0)
