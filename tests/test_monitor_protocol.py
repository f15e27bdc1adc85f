"""The run monitor's protocol without ROS: what it acknowledges and when, the union of
visits, refused replays and statistics that only grow."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_agent.aircraft_sensor import visit_window
from wildfire_agent.dynamics import AircraftState
from wildfire_belief.aggregator import BeliefAggregator
from wildfire_bringup.monitor_protocol import REPORTER, RunMonitor
from wildfire_msgs_py.codecs import NodeStatus
from wildfire_msgs_py.input_guard import InputGuard, RejectedMessage
from wildfire_msgs_py.system_codecs import EpisodeStatus
from wildfire_sim.episode import DECISION_PERIOD_NS as TICK
from wildfire_sim.episode import initial_fire

SEED = 3


def monitor(n: int = 2, union: bool = False) -> RunMonitor:
    return RunMonitor(n, True, SEED, InputGuard(lambda text: None), union_score=union)


def status(tick: int, phase: str = "running", **values: str) -> EpisodeStatus:
    return EpisodeStatus(phase, {"tick": str(tick), **values})


def pose(x: float) -> np.ndarray:
    return np.array([x, 500.0, 0.0, 0.0])


def test_a_tick_is_acknowledged_once_every_next_state_and_its_fire_map_are_in() -> None:
    m = monitor()
    fire = initial_fire(SEED, "circular").burning[0]
    assert m.on_episode(status(0)) == []
    assert m.on_fire_map(0, fire) == []  # no state of tick 1 yet
    assert m.on_state(0, TICK, pose(400.0)) == []
    assert m.on_state(1, TICK, pose(600.0)) == [0]
    assert m.on_episode(status(1)) == []
    m.on_state(0, 2 * TICK, pose(402.0))
    assert m.on_state(1, 2 * TICK, pose(602.0)) == [TICK]
    # The last tick needs no next states.
    assert m.on_episode(status(2, "terminated")) == [2 * TICK]
    assert m.trajectory().shape == (2, 2, 4)
    assert not m.complete
    m.on_episode(status(2, "terminated", complete="true"))
    assert m.complete


def test_the_union_of_visits_is_what_the_aggregator_merges() -> None:
    m = monitor(union=True)
    fire = initial_fire(SEED, "circular").burning[0]
    m.on_episode(status(0))
    m.on_episode(status(1))
    m.on_fire_map(0, fire)
    acks = [m.on_state(k, t * TICK, pose(500.0)) for t in (1, 2) for k in range(2)]
    assert acks == [[], [0], [], []]  # tick 0 has no visits; tick 1 waits for its own
    windows = [
        visit_window(
            AircraftState(*(np.array([v]) for v in (x, 500.0, 0.0)), np.zeros(1, int)), fire
        )
        for x in (480.0, 520.0)
    ]
    assert m.on_visit(0, TICK, windows[0]) == []
    assert m.on_visit(1, TICK, windows[1]) == [TICK]
    reference = BeliefAggregator(fire)
    reference.merge(windows)
    assert m.score == reference.score
    assert np.array_equal(m.final_belief()[0], reference.burning)


def test_replays_are_refused_and_statistics_only_grow() -> None:
    m = monitor()
    fire = np.zeros((100, 100), dtype=bool)
    m.on_fire_map(TICK, fire)
    with pytest.raises(RejectedMessage):
        m.on_fire_map(TICK, fire)
    m.on_score(5.0)
    m.on_score(3.0)
    assert m.ground_score == 5.0 and m.first_heard_after("belief_aggregator", 0.0) is not None

    def deadline(decisions: float) -> NodeStatus:
        return NodeStatus(
            "uav0/agent: decision deadlines", "uav0", "OK", "", {"decisions": decisions}
        )

    m.on_diagnostics([deadline(20.0)])
    m.on_diagnostics([deadline(10.0)])
    assert m.deadlines[0]["decisions"] == 20.0
    m.on_radio(1, 120)
    assert m.radio_bytes.tolist() == [0, 120] and m.radio_messages.tolist() == [0, 1]
    assert REPORTER in m.dropped_inputs()
