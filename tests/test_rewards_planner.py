"""Rewards, pairwise states and the receding-horizon planner on hand-built cases."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from wildfire_agent import pairwise, planner_reference
from wildfire_agent.dynamics import AircraftState, constant_bank_track, propagate
from wildfire_agent.planner_reference import plan_model, score_sequences
from wildfire_agent.policy_names import planner_config
from wildfire_agent.receding_horizon import plan
from wildfire_agent.rewards import (
    ObservationRewardWeights,
    fire_field_maps,
    fire_term_table,
    fire_terms,
    observation_rewards,
    tabled_fire_terms,
)
from wildfire_sim.seeding import Stream, generator


def strip_fire() -> np.ndarray:
    burning = np.zeros((1, 100, 100), dtype=bool)
    burning[0, :, 50] = True  # a north-south line of fire at x = 505 m
    return burning


def test_observation_reward_terms():
    w = ObservationRewardWeights()
    maps = fire_field_maps(strip_fire())
    x = np.array([[505.0, 705.0]])
    y = np.array([[505.0, 505.0]])
    rewards = observation_rewards(maps, x, y, np.array([[0.0, 0.0]]), w)
    # Over the line: distance 0, 81 - 11 = 70 clear cells; proximity to the other at 200 m.
    proximity = np.exp(-200.0 / w.proximity_scale_m)
    assert rewards[0, 0] == pytest.approx(-70 / 81 - proximity)
    assert rewards[0, 1] == pytest.approx(-200 / 500 - 1.0 - proximity)
    banked = observation_rewards(maps, x[:, :1], y[:, :1], np.array([[0.5]]), w)
    assert banked[0, 0] == pytest.approx(-70 / 81 - w.bank * 0.25)


def test_distance_is_capped_and_off_map_cells_count_as_clear():
    maps = fire_field_maps(strip_fire())
    far = fire_terms(maps, np.array([0, 0]), np.array([-2000.0, 1500.0]), np.array([505.0, 505.0]))
    assert far.tolist() == [-2.0, -2.0]


def test_disc_count_map_equals_direct_count():
    rng = np.random.default_rng(1)
    burning = rng.random((2, 100, 100)) < 0.4
    direct = fire_field_maps(burning)
    mapped = fire_field_maps(burning, with_clear_count=True)
    env = np.repeat([0, 1], 300)
    x, y = rng.uniform(-150, 1150, 600), rng.uniform(-150, 1150, 600)
    np.testing.assert_array_equal(fire_terms(direct, env, x, y), fire_terms(mapped, env, x, y))


def test_pairwise_states():
    state = AircraftState(
        x_m=np.array([0.0, 100.0]),
        y_m=np.array([0.0, 100.0]),
        heading_rad=np.array([0.0, np.pi / 2]),
        bank_steps=np.array([2, -3]),
    )
    raw = pairwise.pairwise_states(state)
    assert raw.shape == (2, 1, 5)
    phi0, rho, theta, psi, phi1 = raw[0, 0]
    assert rho == pytest.approx(np.hypot(100, 100))
    assert theta == pytest.approx(np.pi / 4)
    assert psi == pytest.approx(np.pi / 2)
    assert (phi0, phi1) == pytest.approx((np.deg2rad(10), np.deg2rad(-15)))
    # Seen from the second aircraft (heading north), the first is behind-left.
    assert raw[1, 0, 2] == pytest.approx(3 * np.pi / 4)
    alone = pairwise.pairwise_states(AircraftState(*(f[:1] for f in state)))
    assert alone.shape == (1, 1, 5) and alone[0, 0, 1] == pairwise.MAX_RANGE_M
    normalised = pairwise.normalise(raw)
    assert normalised.dtype == np.float32 and np.abs(normalised).max() <= 3.0


def close_pair(other_x_m: float = 500.0) -> tuple[AircraftState, AircraftState]:
    """An ownship flying north along the fire line of :func:`strip_fire`, and another aircraft
    (P = 1, K = 1) 30 m to its left (or at ``other_x_m``), flying the same way."""
    own = AircraftState(
        x_m=np.array([530.0]),
        y_m=np.array([300.0]),
        heading_rad=np.array([np.pi / 2]),
        bank_steps=np.array([0]),
    )
    other = AircraftState(
        x_m=np.array([[other_x_m]]),
        y_m=np.array([[300.0]]),
        heading_rad=np.array([[np.pi / 2]]),
        bank_steps=np.array([[0]]),
    )
    return own, other


def planned(policy: str, other: AircraftState | None = None) -> np.ndarray:
    """The (T,) plan of ``policy`` (rh or rh-paper) for the ownship of :func:`close_pair`."""
    own, close = close_pair()
    config = planner_config(policy)
    assert config is not None
    weights = ObservationRewardWeights()
    maps = fire_field_maps(strip_fire(), weights)
    rngs = [generator(7, Stream.AIRCRAFT, 0)]
    env = np.zeros(1, dtype=np.int64)
    return plan(own, other or close, env, maps, rngs, config, weights)[0]


def test_paper_planner_plans_alone_and_ours_avoids_the_other_aircraft():
    paper, ours = planned("rh-paper"), planned("rh")
    # Deterministic per seed: the restarts come from the aircraft's own stream.
    assert np.array_equal(paper, planned("rh-paper"))
    # No model of the other aircraft: where it flies does not change the plan...
    assert np.array_equal(paper, planned("rh-paper", close_pair(other_x_m=900.0)[1]))
    # ...while ours, 30 m from it, plans otherwise.
    assert not np.array_equal(paper, ours)
    own, close = close_pair()
    weights = ObservationRewardWeights()
    maps = fire_field_maps(strip_fire(), weights, with_clear_count=True)
    env = np.zeros(1, dtype=np.int64)
    with_other = constant_bank_track(close, paper.size)
    alone = (np.zeros((1, 0, paper.size)), np.zeros((1, 0, paper.size)))

    def score(sequence: np.ndarray, others_xy: tuple[np.ndarray, np.ndarray]) -> float:
        model = plan_model(own, env, maps, others_xy, weights)
        return float(score_sequences(model, sequence[None])[0])

    # Each planner's plan is the better one under its own model of the other aircraft.
    assert score(ours, with_other) > score(paper, with_other)
    assert score(paper, alone) > score(ours, alone)


def random_poses(rng: np.random.Generator, shape: tuple[int, ...]) -> AircraftState:
    return AircraftState(
        x_m=rng.uniform(-100.0, 1100.0, shape),
        y_m=rng.uniform(-100.0, 1100.0, shape),
        heading_rad=rng.uniform(-np.pi, np.pi, shape),
        bank_steps=rng.integers(-10, 11, shape),
    )


def test_constant_bank_track_is_stepping_bit_for_bit():
    rng = np.random.default_rng(3)
    state = random_poses(rng, (3, 4))
    state.bank_steps[0, 0] = 0  # wings level: the straight-line branch
    x, y = constant_bank_track(state, 60)
    for t in range(60):
        state = propagate(state)
        assert np.array_equal(x[..., t], state.x_m) and np.array_equal(y[..., t], state.y_m)


def test_tabled_fire_terms_are_fire_terms_bit_for_bit():
    rng = np.random.default_rng(4)
    maps = fire_field_maps(rng.random((2, 100, 100)) < 0.3, with_clear_count=True)
    weights = ObservationRewardWeights()
    # On the map, exactly on its edges and corners, just off it and far off it.
    x = np.concatenate([rng.uniform(-300, 1300, 4000), [0.0, 1000.0, 1000.0, -1e-9, 1000.0001]])
    y = np.concatenate([rng.uniform(-300, 1300, 4000), [1000.0, 0.0, 1000.0, 500.0, 500.0]])
    env = rng.integers(0, 2, x.shape)
    tabled = tabled_fire_terms(fire_term_table(maps, weights), maps, env, x, y, weights)
    assert np.array_equal(tabled, fire_terms(maps, env, x, y, weights))


def test_each_flip_scores_as_the_flipped_sequence_flown_in_full():
    """The planner scores a flip from the decision it changes on; the score must still be
    the float of flying the whole flipped sequence, or plans would depend on the shortcut."""
    rng = np.random.default_rng(5)
    weights = ObservationRewardWeights()
    maps = fire_field_maps(strip_fire(), weights)
    own, others = random_poses(rng, (3,)), random_poses(rng, (3, 2))
    env = np.zeros(3, dtype=np.int64)
    others_xy = constant_bank_track(others, 40)
    actions = rng.integers(0, 2, (3, 40))
    model = plan_model(own, env, maps, others_xy, weights)
    flips = planner_reference.flip_scores(model, actions)
    for j in range(40):
        flipped = actions.copy()
        flipped[:, j] ^= 1
        assert np.array_equal(flips[:, j], score_sequences(model, flipped))


def planning_problem(
    rng: np.random.Generator, rows: int, others: int, horizon: int = 60
) -> tuple[planner_reference.PlanModel, np.ndarray]:
    """Random poses (some off the map) around a random fire, random sequences: one row each."""
    weights = ObservationRewardWeights()
    burning = np.zeros((2, 100, 100), dtype=bool)
    burning[:, 30:70, 35:65] = rng.random((2, 40, 30)) < 0.5
    maps = fire_field_maps(burning, weights)
    own = random_poses(rng, (rows,))
    others_xy = constant_bank_track(random_poses(rng, (rows, others)), horizon)
    model = plan_model(own, rng.integers(0, 2, rows), maps, others_xy, weights)
    return model, rng.integers(0, 2, (rows, horizon))


@pytest.mark.parametrize("others", [0, 1, 3])
def test_compiled_search_equals_the_reference_float_for_float(others):
    from wildfire_agent import planner_compiled

    rng = np.random.default_rng(10 + others)
    for _ in range(3):
        model, sequences = planning_problem(rng, rows=8, others=others)
        compiled = planner_compiled.search(model, sequences, max_sweeps=60)
        reference = planner_reference.search(model, sequences, max_sweeps=60)
        assert np.array_equal(compiled[0], reference[0])
        assert np.array_equal(compiled[1], reference[1])


def test_a_flight_through_a_cell_edge_is_settled_exactly():
    """Estimates are unsure where a position lies on a cell edge (the fire term jumps
    there): such flips are scored exactly, and the search still equals the reference."""
    from wildfire_agent import planner_compiled

    rng = np.random.default_rng(12)
    model, sequences = planning_problem(rng, rows=2, others=1)
    # Put flip 0's first position 1e-9 m north of the edge y = 500 m.
    heading = model.own.heading_rad[:, 0]
    level = planner_reference.NEXT_LEVEL[model.own.bank_steps[:, 0] + 10, sequences[:, 0] ^ 1]
    first_dy = planner_reference.AHEAD_M[level] * np.sin(heading) + planner_reference.LEFT_M[
        level
    ] * np.cos(heading)
    model = model._replace(own=model.own._replace(y_m=(500.0 + 1e-9 - first_dy)[:, None]))
    _, unsure = planner_compiled.flip_estimates(model, sequences)
    assert unsure[:, 0].all()
    compiled = planner_compiled.search(model, sequences, max_sweeps=60)
    reference = planner_reference.search(model, sequences, max_sweeps=60)
    assert np.array_equal(compiled[0], reference[0])
    assert np.array_equal(compiled[1], reference[1])


def test_flip_estimates_are_far_inside_their_tolerance():
    from wildfire_agent import planner_compiled

    rng = np.random.default_rng(13)
    model, sequences = planning_problem(rng, rows=8, others=2)
    estimates, unsure = planner_compiled.flip_estimates(model, sequences)
    exact = planner_reference.flip_scores(model, sequences)
    error = np.abs(estimates - exact)[~unsure]
    assert error.max() < planner_compiled.ESTIMATE_TOLERANCE / 1000


def test_compiled_track_is_the_dynamics_track_bit_for_bit():
    from wildfire_agent import planner_compiled

    rng = np.random.default_rng(14)
    state = random_poses(rng, (3, 4))
    state.bank_steps[0, 0] = 0
    expected = constant_bank_track(state, 60)
    compiled = planner_compiled.constant_bank_track(state, 60)
    assert np.array_equal(compiled[0], expected[0]) and np.array_equal(compiled[1], expected[1])


@pytest.mark.parametrize("policy", ["rh", "rh-paper"])
def test_compiled_plans_equal_reference_plans_in_episodes(policy):
    """Every plan of two 3-aircraft episodes, planned by both searches."""
    from wildfire_bench.core import capture_plans

    problems = capture_plans(n_aircraft=3, decisions=60)
    assert len(problems) > 10
    for problem in problems:
        problem = problem._replace(config=planner_config(policy))
        planned = [
            plan(*problem._replace(generators=copy.deepcopy(problem.generators)), reference=ref)
            for ref in (False, True)
        ]
        assert np.array_equal(*planned)
