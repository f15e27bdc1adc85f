"""The belief aggregator's protocol without DDS: visits in, belief and acknowledgements out.

Lockstep merges a tick only once every aircraft's visit of it is in, whatever the arrival
order, and equals calling :class:`~wildfire_belief.aggregator.BeliefAggregator` directly;
duplicates, replays and far-ahead visits are refused; a restarted real-time aggregator
recovers from the newest snapshot or, after the timeout, from the ignition seed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from wildfire_agent.aircraft_sensor import visit_window
from wildfire_agent.dynamics import AircraftState
from wildfire_belief.aggregator import BeliefAggregator
from wildfire_belief.aggregator_protocol import (
    NAME,
    AckOut,
    AggregatorProtocol,
    BeliefOut,
    LogOut,
    RequestOut,
)
from wildfire_msgs_py.codecs import VisitWindow
from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.system_codecs import READY_SUFFIX, BeliefSnapshot, EpisodeStatus
from wildfire_sim.episode import DECISION_PERIOD_NS, Mode, initial_fire

TICK = DECISION_PERIOD_NS
IGNITION = initial_fire(3, "circular").burning[0]


def status(tick: int, phase: str = "running") -> EpisodeStatus:
    return EpisodeStatus(phase, {"tick": str(tick)})


def window(k: int, tick: int) -> VisitWindow:
    """A visit of aircraft ``k`` at ``tick`` somewhere over the fire."""
    x, y = 480.0 + 7.0 * tick, 430.0 + 40.0 * k
    pose = AircraftState(np.array([x]), np.array([y]), np.zeros(1), np.zeros(1, dtype=np.int64))
    return visit_window(pose, IGNITION)


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def started(n: int, mode: Mode = Mode.LOCKSTEP, clock: Any = None) -> AggregatorProtocol:
    protocol = AggregatorProtocol(n, mode, IGNITION, lambda: 5 * TICK, 3.0, clock or Clock())
    assert protocol.on_startup(lambda: True) == []  # no status yet: fresh start or restart?
    protocol.on_status(status(-1, "waiting"))
    assert protocol.on_startup(lambda: False) == []  # the agents' visits are not matched yet
    out = protocol.on_startup(lambda: True)
    assert [type(o) for o in out] == [BeliefOut, AckOut]
    assert out[1] == AckOut(NAME + READY_SUFFIX, 0)
    return protocol


def refused(call: Any, *args: Any) -> DropReason:
    with pytest.raises(RejectedMessage) as error:
        call(*args)
    return error.value.reason


def test_lockstep_merges_when_every_visit_is_in_and_equals_the_aggregator() -> None:
    protocol = started(2)
    reference = BeliefAggregator(IGNITION)
    assert protocol.on_status(status(0)) == [AckOut(NAME, 0)]
    # Visits of tick 2 before tick 1's, and before tick 2 is announced.
    assert protocol.on_visit(1, 2 * TICK, window(1, 2)) == []
    assert protocol.on_visit(0, 2 * TICK, window(0, 2)) == []
    assert protocol.on_visit(0, TICK, window(0, 1)) == []
    assert protocol.on_status(status(1)) == []  # uav1's visit of tick 1 missing
    assert protocol.on_status(status(2)) == []
    out = protocol.on_visit(1, TICK, window(1, 1))  # releases ticks 1 and 2 at once
    assert [type(o) for o in out] == [BeliefOut, AckOut, BeliefOut, AckOut]
    assert (out[1], out[3]) == (AckOut(NAME, TICK), AckOut(NAME, 2 * TICK))
    reference.merge([window(0, 1), window(1, 1)])
    assert np.array_equal(out[0].burning, reference.burning)  # not tick 2's
    assert np.array_equal(out[0].age_s, reference.age_s())
    reference.merge([window(0, 2), window(1, 2)])
    out = out[2:]
    belief = out[0]
    assert belief.stamp == 2 * TICK and belief.score == reference.score
    assert np.array_equal(belief.burning, reference.burning)
    assert np.array_equal(belief.age_s, reference.age_s())


def test_duplicates_replays_and_far_ahead_visits_are_refused() -> None:
    protocol = started(2)
    protocol.on_status(status(0))
    protocol.on_status(status(1))
    first = window(0, 1)
    protocol.on_visit(0, TICK, first)
    assert refused(protocol.on_visit, 0, TICK, window(0, 5)) is DropReason.DUPLICATE
    assert protocol.visits[0].get(TICK) is first
    protocol.on_visit(1, TICK, window(1, 1))  # tick 1 merged
    assert refused(protocol.on_visit, 0, TICK, first) is DropReason.STALE
    assert refused(protocol.on_visit, 1, 60 * TICK, first) is DropReason.FUTURE
    assert refused(protocol.on_visit, 1, TICK + 1, first) is DropReason.STALE
    assert refused(protocol.on_visit, 1, 2 * TICK + 1, first) is DropReason.OUT_OF_RANGE
    assert refused(protocol.on_status, status(9)) is DropReason.FUTURE


def test_a_vanished_aircraft_stalls_the_merge_without_error() -> None:
    protocol = started(3)
    for tick in range(4):
        protocol.on_status(status(tick))
    for tick in (1, 2, 3):
        assert protocol.on_visit(0, tick * TICK, window(0, tick)) == []
        assert protocol.on_visit(1, tick * TICK, window(1, tick)) == []
    assert protocol.aggregator.ticks == 0


def test_realtime_merges_on_the_timer() -> None:
    protocol = started(2, Mode.REALTIME)
    protocol.on_status(status(0))
    protocol.on_visit(0, 3 * TICK, window(0, 1))
    protocol.on_visit(1, 2 * TICK, window(1, 1))
    assert refused(protocol.on_visit, 0, 3 * TICK, window(0, 1)) is DropReason.STALE
    out = protocol.on_timer()
    assert [type(o) for o in out] == [BeliefOut] and out[0].stamp == 5 * TICK
    assert protocol.aggregator.ticks == 1 and protocol.realtime_queue == []


def test_a_restarted_aggregator_recovers_the_newest_snapshot() -> None:
    clock = Clock()
    protocol = AggregatorProtocol(2, Mode.REALTIME, IGNITION, lambda: 0, 3.0, clock)
    out = protocol.on_status(status(75))
    assert [type(o) for o in out] == [LogOut, RequestOut] and out[0].warning
    assert protocol.on_startup(lambda: True) == []  # waits for a copy
    believed = np.zeros_like(IGNITION)
    ages = np.full(IGNITION.shape, 2.0, dtype=np.float32)
    protocol.on_snapshot(BeliefSnapshot(7.0, 40.0, believed, ages))
    protocol.on_snapshot(BeliefSnapshot(7.5, 42.0, believed, ages))
    out = protocol.on_startup(lambda: True)
    assert [type(o) for o in out] == [LogOut, BeliefOut]  # no second ready
    assert out[1].score == 42.0 and protocol.started
    protocol.on_snapshot(BeliefSnapshot(9.0, 50.0, believed, ages))  # too late: ignored
    assert protocol.snapshots[-1].time_s == 7.5


def test_a_restart_without_copies_starts_from_the_ignition_after_the_timeout() -> None:
    clock = Clock()
    protocol = AggregatorProtocol(2, Mode.REALTIME, IGNITION, lambda: 0, 3.0, clock)
    protocol.on_status(status(75))
    clock.now = 2.9
    assert protocol.on_startup(lambda: True) == []
    clock.now = 3.1
    out = protocol.on_startup(lambda: True)
    assert [type(o) for o in out] == [LogOut, BeliefOut, AckOut] and out[0].warning
    assert np.array_equal(out[1].burning, IGNITION)


def test_under_cameras_a_tick_waits_for_every_camera_and_its_fire_map() -> None:
    from wildfire_agent.aircraft_sensor import AircraftSensor
    from wildfire_belief.filtered_aggregator import FilteredAggregator

    seed = 3
    filtered = FilteredAggregator(seed, "circular", 0.1)
    protocol = AggregatorProtocol(
        1, Mode.LOCKSTEP, IGNITION, lambda: 0, 3.0, Clock(), filtered=filtered, sources=4
    )
    protocol.on_status(status(-1, "waiting"))
    protocol.on_startup(lambda: True)
    protocol.on_status(status(0))
    protocol.on_status(status(1))
    pose = AircraftState(np.array([480.0]), np.array([300.0]), np.ones(1), np.array([2]))
    reports = AircraftSensor("camera", 0.1, seed, 0).report(pose, IGNITION)
    for c, report in enumerate(reports):
        assert protocol.on_visit(c, TICK, report) == []  # no fire map yet: no score
    out = protocol.on_fire_map(0, IGNITION)  # tick 1 holds the fire map of tick 0
    assert [type(o) for o in out] == [BeliefOut, AckOut]
    reference = FilteredAggregator(seed, "circular", 0.1)
    reference.merge(list(reports), IGNITION)
    belief = out[0]
    assert belief.score == reference.score and belief.probability is not None
    np.testing.assert_array_equal(belief.probability, reference.probability())
    np.testing.assert_array_equal(belief.burning, reference.burning)
