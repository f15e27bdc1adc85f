"""The node side of noisy sensing replays the environment: each aircraft's own sensor
(``AircraftSensor``, as the agent node draws it) and one episode's filtered belief
(``FilteredAggregator``, as the aggregator node and the run monitor keep it) give the
environment's beliefs, ages and score, tick by tick and bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_agent.aircraft_sensor import AircraftSensor, check_sensing
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_belief.filtered_aggregator import FilteredAggregator
from wildfire_belief.sensors import sensors_of
from wildfire_world.env import EnvConfig, WildfireVecEnv


@pytest.mark.parametrize(("sensor", "pixel_error"), [("camera", 0.1), ("disc", 0.2)])
def test_the_nodes_fuse_what_the_environment_fuses(sensor: str, pixel_error: float) -> None:
    seed, n = 2000003, 2
    config = EnvConfig(sensor=sensor, pixel_error=pixel_error, observation="none", reward="belief")
    env = WildfireVecEnv(config, 2)
    env.reset([seed + 1, seed])  # the episode under test is environment 1: the batch is moot
    sensors = [AircraftSensor(sensor, pixel_error, seed, k) for k in range(n)]
    shape = env.shapes[1].value
    team = FilteredAggregator(seed, shape, pixel_error, config.preburn_steps)
    assert env.sensing is not None
    np.testing.assert_array_equal(team.belief.log_odds[0], env.sensing.belief.log_odds[1])
    rng = np.random.default_rng(5)
    for _ in range(250):
        result = env.step(rng.integers(0, 2, size=(2, n)))
        truth = env.truth[1].astype(bool)
        windows = []
        for k, aircraft in enumerate(sensors):
            pose = AircraftState(*(field[1, k : k + 1] for field in env.aircraft))
            reports = aircraft.report(pose, truth)
            assert len(reports) == sensors_of(sensor)
            windows += reports
        reward = team.merge(windows, truth)
        assert reward == result.team_reward[1]
        np.testing.assert_array_equal(team.belief.log_odds[0], env.sensing.belief.log_odds[1])
        np.testing.assert_array_equal(team.age_s(), env.belief_age_s()[1])
        if env.done[1]:
            break
    assert team.score == env.scores[1] > 0
    assert team.false_alarms == env.sensing.false_alarms[1]
    assert team.flipped_fraction() == env.sensing.flipped_fraction()[1]
    assert team.ticks == env.decisions[1]


def test_the_perfect_disc_reports_the_truth_in_one_window() -> None:
    sensor = AircraftSensor("disc", 0.0, 7, 0)
    assert sensor.rng is None
    pose = AircraftState(np.array([500.0]), np.array([500.0]), np.zeros(1), np.zeros(1, int))
    burning = np.zeros((100, 100), dtype=bool)
    burning[50, 50] = True
    (window,) = sensor.report(pose, burning)
    assert window.burning[50 - window.row0, 50 - window.col0]
    assert window.burning.sum() == 1
    assert window.visited.sum() == 316  # the cells whose centre lies within 100 m


@pytest.mark.parametrize(
    ("sensor", "pixel_error", "names"),
    [("radar", 0.1, "sensor 'radar'"), ("camera", 0.5, "pixel_error 0.5"), ("disc", -0.1, "0 <=")],
)
def test_bad_sensor_parameters_name_what_was_expected(
    sensor: str, pixel_error: float, names: str
) -> None:
    with pytest.raises(AgentConfigError, match=names):
        check_sensing(sensor, pixel_error)


def test_a_restarted_filtered_belief_continues_from_a_copy() -> None:
    from wildfire_belief.filtered_aggregator import FilteredAggregator

    rng = np.random.default_rng(4)
    believed = rng.random((100, 100)) < 0.2
    ages = np.rint(rng.random((100, 100)) * 500) / 10
    team = FilteredAggregator(7, "circular", 0.1)
    team.restore(12.3, 40.0, believed, ages)
    assert (team.ticks, team.score) == (123, 40)
    np.testing.assert_array_equal(team.burning, believed)
    np.testing.assert_allclose(team.age_s(), ages, atol=1e-4)
