"""Hostile input, node side: the checks, the per-stamp inbox and the drop counters (no DDS)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from wildfire_agent.dynamics import BANK_STEP_RAD, MAX_BANK_STEPS
from wildfire_belief.visits import VISIT_WINDOW
from wildfire_msgs_py import belief_codec, codecs, system_codecs, wire_checks
from wildfire_msgs_py.input_guard import (
    DropReason,
    InputGuard,
    RejectedMessage,
    TickInbox,
    check_status_tick,
)

MAX_BANK = float(MAX_BANK_STEPS * BANK_STEP_RAD)
TICK = 100_000_000


def reason_of(check: Any, *args: Any) -> DropReason:
    with pytest.raises(RejectedMessage) as caught:
        check(*args)
    return caught.value.reason


def test_honest_messages_pass_every_check() -> None:
    burning = np.random.default_rng(0).random((100, 100)) < 0.3
    stamp, decoded = wire_checks.checked_fire_grid(codecs.fire_grid_to_msg(burning, 25 * TICK))
    assert stamp == 25 * TICK and np.array_equal(decoded, burning)
    ages = np.random.default_rng(1).random((100, 100)).astype(np.float32) * 200
    _, back = wire_checks.checked_age_image(system_codecs.age_image_to_msg(ages, TICK))
    assert np.array_equal(back, ages)
    state = np.array([512.5, -40.0, 7.25, -MAX_BANK])
    msg = system_codecs.stamped_state_to_msg(state, 3 * TICK)
    assert wire_checks.checked_stamped_state(msg, MAX_BANK)[1].tobytes() == state.tobytes()
    visited = np.zeros((VISIT_WINDOW, VISIT_WINDOW), dtype=bool)
    visited[5:9, 5:9] = True
    window = codecs.VisitWindow(-3, 90, visited, visited & (np.arange(VISIT_WINDOW) % 2 == 0))
    assert wire_checks.checked_visit(codecs.visit_to_msg(window, TICK), VISIT_WINDOW)[1] == window
    status = system_codecs.episode_to_msg("running", {"tick": 7, "seed": 3, "complete": "false"})
    assert wire_checks.checked_episode(status, 3).tick == 7
    ack = system_codecs.ack_to_msg("uav1/ready", 0)
    assert wire_checks.checked_ack(ack, {"uav1"}) == ("uav1/ready", 0)
    assert wire_checks.checked_score(codecs.score_to_msg(12.0)) == 12.0


def test_malformed_and_out_of_range_grids_are_rejected() -> None:
    grid = codecs.fire_grid_to_msg(np.zeros((100, 100), dtype=bool), 0)
    grid.data = grid.data[:9]
    with pytest.raises(Exception, match="9 data values"):
        wire_checks.checked_fire_grid(grid)
    small = codecs.fire_grid_to_msg(np.zeros((30, 30), dtype=bool), 0)
    assert reason_of(wire_checks.checked_fire_grid, small) is DropReason.MALFORMED
    odd = codecs.grid_to_msg(np.full((100, 100), 37, dtype=np.int8))
    assert reason_of(wire_checks.checked_fire_grid, odd) is DropReason.OUT_OF_RANGE
    framed = codecs.fire_grid_to_msg(np.zeros((100, 100), dtype=bool), 0)
    framed.header.frame_id = "odom"
    assert reason_of(wire_checks.checked_fire_grid, framed) is DropReason.WRONG_FRAME
    ages = system_codecs.age_image_to_msg(np.full((100, 100), np.nan, dtype=np.float32), 0)
    assert reason_of(wire_checks.checked_age_image, ages) is DropReason.OUT_OF_RANGE


@pytest.mark.parametrize(
    "state",
    [[math.nan, 0, 0, 0], [0, math.inf, 0, 0], [2e5, 0, 0, 0], [0, 0, 0, MAX_BANK + 0.01]],
)
def test_out_of_range_states_are_rejected(state: list[float]) -> None:
    msg = system_codecs.stamped_state_to_msg(np.array(state, dtype=float), TICK)
    assert reason_of(wire_checks.checked_stamped_state, msg, MAX_BANK) is DropReason.OUT_OF_RANGE


def test_bad_visits_acks_episodes_and_scores_are_rejected() -> None:
    window = codecs.VisitWindow(0, 0, np.ones((5, 5), bool), np.zeros((5, 5), bool))
    assert (
        reason_of(wire_checks.checked_visit, codecs.visit_to_msg(window), VISIT_WINDOW)
        is DropReason.MALFORMED
    )
    far = codecs.VisitWindow(
        10_000, 0, np.ones((VISIT_WINDOW,) * 2, bool), np.zeros((VISIT_WINDOW,) * 2, bool)
    )
    assert (
        reason_of(wire_checks.checked_visit, codecs.visit_to_msg(far), VISIT_WINDOW)
        is DropReason.OUT_OF_RANGE
    )
    edge = codecs.VisitWindow(
        -15, 40, np.ones((VISIT_WINDOW,) * 2, bool), np.zeros((VISIT_WINDOW,) * 2, bool)
    )
    assert (
        reason_of(wire_checks.checked_visit, codecs.visit_to_msg(edge), VISIT_WINDOW)
        is DropReason.OUT_OF_RANGE
    )
    stranger = system_codecs.ack_to_msg("intruder", 0)
    assert reason_of(wire_checks.checked_ack, stranger, {"uav0"}) is DropReason.WRONG_FRAME
    garbled = system_codecs.episode_to_msg("running", {"tick": "soon", "seed": 3})
    assert reason_of(wire_checks.checked_episode, garbled, 3) is DropReason.MALFORMED
    other = system_codecs.episode_to_msg("running", {"tick": 1, "seed": 4})
    assert reason_of(wire_checks.checked_episode, other, 3) is DropReason.WRONG_FRAME
    assert (
        reason_of(wire_checks.checked_score, codecs.score_to_msg(-1.0)) is DropReason.OUT_OF_RANGE
    )
    assert (
        reason_of(wire_checks.checked_score, codecs.score_to_msg(math.nan))
        is DropReason.OUT_OF_RANGE
    )


def test_inbox_keeps_the_first_message_per_stamp_and_refuses_replays() -> None:
    inbox: TickInbox[str] = TickInbox(TICK)
    inbox.ceiling = 10 * TICK
    inbox.accept(2 * TICK, "first")
    assert reason_of(inbox.accept, 2 * TICK, "forged") is DropReason.DUPLICATE
    assert inbox.get(2 * TICK) == "first"
    assert reason_of(inbox.accept, 11 * TICK, "ahead") is DropReason.FUTURE
    assert reason_of(inbox.accept, TICK + 1, "between ticks") is DropReason.OUT_OF_RANGE
    inbox.accept(5 * TICK, "later")
    inbox.discard_below(3 * TICK)
    assert 2 * TICK not in inbox and len(inbox) == 1
    assert reason_of(inbox.accept, 2 * TICK, "replay") is DropReason.STALE
    for tick in (6, 7, 8, 9):
        inbox.accept(tick * TICK, str(tick))
    inbox.keep_newest(2)
    assert sorted(inbox.items) == [8 * TICK, 9 * TICK] and inbox.latest() == (9 * TICK, "9")


def test_status_far_ahead_is_refused() -> None:
    check_status_tick(0, -1, True, 50)
    check_status_tick(3, 7, True, 50)  # a replay of an earlier tick is harmless
    assert reason_of(check_status_tick, 1, -1, True, 50) is DropReason.FUTURE  # lockstep: 0 first
    assert reason_of(check_status_tick, 9, 7, True, 50) is DropReason.FUTURE
    check_status_tick(5_000, -1, False, 50)  # a restarted node joins a running episode
    check_status_tick(60, 10, False, 50)
    assert reason_of(check_status_tick, 61, 10, False, 50) is DropReason.FUTURE


def test_guard_counts_every_drop_and_logs_at_a_limited_rate() -> None:
    lines: list[str] = []
    now = [0.0]
    guard = InputGuard(lines.append, log_period_s=5.0, clock=lambda: now[0])

    def callback(msg: Any) -> None:
        if msg == "bad":
            raise RejectedMessage(DropReason.OUT_OF_RANGE, "bad value")
        if msg == "garbled":
            raise ValueError("cannot reshape array")

    guarded = guard.guarded("/uav0/state_stamped", callback)
    for _ in range(100):
        guarded("bad")
        guarded("garbled")
        guarded("good")
    assert guard.total == 200 and len(lines) == 1
    now[0] = 6.0
    guarded("bad")
    assert len(lines) == 2 and "199 more dropped" in lines[1]
    status = guard.status("uav0/agent", "uav0")
    assert status.level == "WARN" and status.values["dropped"] == 201
    assert status.values["/uav0/state_stamped out of range"] == 101
    assert status.values["/uav0/state_stamped malformed"] == 100
    assert InputGuard(print).status("x", "x").level == "OK"


def test_camera_reports_of_the_wrong_size_frame_or_place_are_rejected() -> None:
    from wildfire_agent.aircraft_sensor import AircraftSensor
    from wildfire_agent.dynamics import AircraftState
    from wildfire_belief.sensors import CAMERA_WINDOW

    pose = AircraftState(np.array([480.0]), np.array([300.0]), np.ones(1), np.array([3]))
    burning = np.random.default_rng(2).random((100, 100)) < 0.2
    for window in AircraftSensor("camera", 0.1, 7, 0).report(pose, burning):
        msg = codecs.visit_to_msg(window, TICK)
        assert wire_checks.checked_visit(msg, CAMERA_WINDOW) == (TICK, window)
        assert reason_of(wire_checks.checked_visit, msg, VISIT_WINDOW) is DropReason.MALFORMED
        msg.header.frame_id = "uav0/base_link"
        assert reason_of(wire_checks.checked_visit, msg, CAMERA_WINDOW) is DropReason.WRONG_FRAME
    side = (CAMERA_WINDOW,) * 2
    beyond = codecs.VisitWindow(40, 80, np.ones(side, bool), np.zeros(side, bool))
    assert (
        reason_of(wire_checks.checked_visit, codecs.visit_to_msg(beyond), CAMERA_WINDOW)
        is DropReason.OUT_OF_RANGE
    )


def test_the_belief_grid_keeps_the_believed_side_of_one_half() -> None:
    probability = np.linspace(0.0, 1.0, 10_000).reshape(100, 100)
    probability[0, :3] = (0.5, 0.503, 0.497)  # round to 50 on either side of the threshold
    believed = probability > 0.5
    msg = belief_codec.belief_to_msg(believed, TICK, probability=probability)
    stamp, decoded = wire_checks.checked_belief_grid(msg)
    assert stamp == TICK and decoded.dtype == np.float32
    assert np.array_equal(belief_codec.believed_burning(decoded), believed)
    assert np.all(np.abs(decoded - probability) <= 0.01 + 1e-6)
    # What the environment shows a belief network is exactly what an agent decodes.
    assert np.array_equal(decoded, belief_codec.published_probability(believed, probability))
    disc = belief_codec.belief_to_msg(believed, TICK)
    assert set(np.unique(codecs.grid_from_msg(disc))) == {0, 100}
    odd = codecs.grid_to_msg(np.full((100, 100), 101, dtype=np.int8))
    assert reason_of(wire_checks.checked_belief_grid, odd) is DropReason.OUT_OF_RANGE
