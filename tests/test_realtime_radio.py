"""Limited radio links in real time, without ROS: an aircraft that hears its peers' messages
late and in any order believes what the lockstep aircraft believes, and each slot has a tick."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_agent import dynamics
from wildfire_agent.aircraft_radio import AircraftRadio, window_of
from wildfire_agent.aircraft_sensor import visit_window
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.radio_ticks import RadioTicks
from wildfire_belief.radio import CommModel
from wildfire_msgs_py.codecs import VisitWindow
from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.radio_codec import RadioMessage
from wildfire_sim.episode import AHEAD_TICKS, DECISION_PERIOD_NS

N, TICKS, SEED = 3, 80, 41


def flights(seed: int) -> tuple[list[AircraftState], np.ndarray]:
    """Three aircraft banking at random near the map's centre: (start, then every tick's
    poses), fields (N,) each, and a burning map."""
    rng = np.random.default_rng(seed)
    burning = rng.random((100, 100)) < 0.3
    state = AircraftState(
        np.array([450.0, 550.0, 500.0]),
        np.array([500.0, 450.0, 620.0]),
        np.array([0.0, 2.0, 4.0]),
        np.zeros(N, dtype=np.int64),
    )
    poses = [state]
    for _ in range(TICKS):
        state = dynamics.step(state, rng.integers(0, 2, N))
        poses.append(state)
    return poses, burning


def one(state: AircraftState, k: int) -> AircraftState:
    return AircraftState(*(np.asarray(f)[k : k + 1] for f in state))


@pytest.mark.parametrize("comm", ["range=300,loss=0.2,delay=2", "range=1e9,outage=2-4"])
def test_late_and_reordered_messages_build_the_lockstep_replica(comm: str) -> None:
    model = CommModel.parse(comm)
    poses, burning = flights(SEED)
    senders = {j: AircraftRadio(model, j, N, SEED, burning) for j in (1, 2)}
    lockstep = AircraftRadio(model, 0, N, SEED, burning)
    realtime = AircraftRadio(model, 0, N, SEED, burning)
    for radio in (lockstep, realtime):
        radio.start(poses[0])
    rng = np.random.default_rng(SEED + 1)
    arrivals: dict[int, list[tuple[RadioMessage, VisitWindow]]] = {}  # by arrival tick
    newest_arrival = {1: 0, 2: 0}
    sent = []
    for tick in range(1, TICKS + 1):
        own = one(poses[tick], 0)
        own_window = visit_window(own, burning)
        peers = {}
        for j, sender in senders.items():
            message = sender.message(
                tick, one(poses[tick], j), visit_window(one(poses[tick], j), burning)
            )
            peers[j] = (message, window_of(message))
            sent.append(message)
            # Late by up to 8 ticks, but in order per peer (a real-time agent refuses older).
            newest_arrival[j] = max(newest_arrival[j], tick + int(rng.integers(0, 9)))
            arrivals.setdefault(newest_arrival[j], []).append(peers[j])
        lockstep.receive(tick, own, own_window, peers)
        realtime.visit(tick, own, own_window)
        for received in rng.permutation(len(arrivals.get(tick, []))):
            realtime.accept(*arrivals[tick][received])
        realtime.hear_due(tick)
    for late in (t for t in arrivals if t > TICKS):
        for received in arrivals[late]:
            realtime.accept(*received)
    realtime.hear_due(TICKS)

    assert np.array_equal(realtime.replica.key, lockstep.replica.key)
    assert np.array_equal(realtime.replica.burning, lockstep.replica.burning)
    assert np.array_equal(realtime.heard.tick, lockstep.heard.tick)
    for heard, expected in zip(realtime.heard.pose, lockstep.heard.pose, strict=True):
        assert np.array_equal(heard, expected)
    # The model did decide: some messages reached the aircraft and some did not.
    reached = [lockstep.reaches(m) for m in sent]
    assert 0 < sum(reached) < len(reached)


def test_a_message_is_decided_from_both_positions_at_its_send_tick() -> None:
    poses, burning = flights(SEED)
    radio = AircraftRadio(CommModel.parse("range=300"), 0, N, SEED, burning)
    sender = AircraftRadio(CommModel.parse("range=300"), 1, N, SEED, burning)
    near = one(poses[1], 1)._replace(x_m=np.array([float(poses[1].x_m[0]) + 100.0]))
    radio.visit(1, one(poses[1], 0), visit_window(one(poses[1], 0), burning))
    far = one(poses[1], 0)._replace(x_m=np.array([float(poses[1].x_m[0]) + 900.0]))
    radio.visit(2, far, visit_window(far, burning))  # we flew away after tick 1
    message = sender.message(1, near, visit_window(near, burning))
    assert radio.reaches(message)  # 100 m apart at tick 1, whatever came after
    later = sender.message(2, near, visit_window(near, burning))
    assert not radio.reaches(later)


def test_each_slot_takes_the_status_tick_plus_the_periods_since_and_never_repeats() -> None:
    ticks = RadioTicks([1, 2])
    assert ticks.next(0) == 1  # no status yet: count slots
    ticks.on_status(25, 10 * DECISION_PERIOD_NS)
    assert ticks.next(10 * DECISION_PERIOD_NS + 3) == 25
    assert ticks.next(13 * DECISION_PERIOD_NS) == 28
    assert ticks.next(13 * DECISION_PERIOD_NS + 5) == 29  # a slot early: still a new tick
    ticks.on_status(20, 30 * DECISION_PERIOD_NS)  # an older status changes nothing
    assert ticks.anchor == (25, 10 * DECISION_PERIOD_NS)

    ticks.take(1, 29)
    for tick, reason in ((29, DropReason.STALE), (3, DropReason.STALE)):
        with pytest.raises(RejectedMessage) as error:
            ticks.take(1, tick)
        assert error.value.reason is reason
    with pytest.raises(RejectedMessage) as error:
        ticks.take(2, 29 + AHEAD_TICKS + 1)
    assert error.value.reason is DropReason.FUTURE
    ticks.take(2, 29 + AHEAD_TICKS)


@pytest.mark.parametrize("comm", ["range=300,loss=0.2,delay=2", "range=1e9,outage=2-4"])
def test_late_and_reordered_camera_reports_build_the_lockstep_filtered_replica(comm: str) -> None:
    """Under noisy sensing the messages carry each camera's reports: an aircraft hearing them
    late (across fire steps) and in any order, catch-up replies included, ends with the
    lockstep aircraft's filtered replica, bit for bit."""
    from wildfire_agent.aircraft_report_radio import AircraftReportRadio
    from wildfire_agent.aircraft_sensor import AircraftSensor

    model = CommModel.parse(comm)
    poses, burning = flights(SEED)
    ignition, fuel = burning & (np.random.default_rng(3).random(burning.shape) < 0.1), ~burning

    def radio(k: int) -> AircraftReportRadio:
        return AircraftReportRadio(model, k, N, SEED, "camera", 0.1, ignition, fuel, 2)

    sensors = {k: AircraftSensor("camera", 0.1, SEED, k) for k in range(N)}
    senders = {j: radio(j) for j in (1, 2)}
    lockstep, realtime = radio(0), radio(0)
    for each in (lockstep, realtime, *senders.values()):
        each.start(poses[0])
    rng = np.random.default_rng(SEED + 1)
    arrivals: dict[int, list[tuple[RadioMessage, tuple[VisitWindow, ...]]]] = {}
    newest_arrival = {1: 0, 2: 0}
    for tick in range(1, TICKS + 1):
        reports = {k: sensors[k].report(one(poses[tick], k), burning) for k in range(N)}
        peers = {}
        for j, sender in senders.items():
            message = sender.message(tick, one(poses[tick], j), reports[j])
            peers[j] = (message, lockstep.payload_of(message))
            newest_arrival[j] = max(newest_arrival[j], tick + int(rng.integers(0, 9)))
            arrivals.setdefault(newest_arrival[j], []).append(peers[j])
        # The senders hear each other and the aircraft in lockstep (their catch-ups need it).
        own_message = lockstep.message(tick, one(poses[tick], 0), reports[0])
        realtime.message(tick, one(poses[tick], 0), reports[0])
        heard = {0: (own_message, lockstep.payload_of(own_message)), **peers}
        for j, sender in senders.items():
            others = {i: m for i, m in heard.items() if i != j}
            sender.receive(tick, one(poses[tick], j), reports[j], others)
        lockstep.receive(tick, one(poses[tick], 0), reports[0], peers)
        realtime.visit(tick, one(poses[tick], 0), reports[0])
        for received in rng.permutation(len(arrivals.get(tick, []))):
            realtime.accept(*arrivals[tick][received])
        realtime.hear_due(tick)
    for late in (t for t in arrivals if t > TICKS):
        for received in arrivals[late]:
            realtime.accept(*received)
    realtime.hear_due(TICKS)

    ours, theirs = realtime.replicas.belief, lockstep.replicas.belief
    assert np.array_equal(ours.log_odds, theirs.log_odds)
    assert np.array_equal(ours.last_report, theirs.last_report)
    assert realtime.replicas.too_old.sum() == 0
    # The outage's catch-ups were heard, and each held reports the aircraft had missed.
    assert "outage" not in comm or any(cells for *_, cells in lockstep.catch_ups.done)


def test_camera_radio_messages_that_lie_are_dropped_with_their_reason() -> None:
    """A camera message whose bits do not fit the footprints its pose makes, or whose
    catch-up reply names an aircraft outside the team, is refused before any replica."""
    from wildfire_agent.aircraft_report_radio import AircraftReportRadio
    from wildfire_agent.aircraft_sensor import AircraftSensor
    from wildfire_msgs_py.radio_codec import Reply

    poses, burning = flights(SEED)
    model = CommModel.parse("range=300")
    sender, receiver = (
        AircraftReportRadio(model, k, N, SEED, "camera", 0.1, burning, ~burning, 0) for k in (1, 0)
    )
    state = one(poses[1], 1)
    message = sender.message(
        1, state, AircraftSensor("camera", 0.1, SEED, 1).report(state, burning)
    )
    assert sum(w.visited.sum() for w in receiver.payload_of(message)) > 0  # the honest one reads
    for lie, reason in (
        (message._replace(bits=message.bits[:-1]), DropReason.MALFORMED),
        (message._replace(x_m=message.x_m + 400.0), DropReason.MALFORMED),
        (
            message._replace(
                replies=(Reply(0, np.array([5], np.uint32), np.array([1], np.uint32),
                               np.array([N], np.uint8), np.array([True])),)
            ),
            DropReason.OUT_OF_RANGE,
        ),
    ):  # fmt: skip
        with pytest.raises(RejectedMessage) as refused:
            receiver.payload_of(lie)
        assert refused.value.reason is reason
