"""Fleets of up to 32 aircraft: each ownship sees its nearest peers, the starts spread over
the fires, and a 32-aircraft fleet flies a 10 km map."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from wildfire_agent.dynamics import AircraftState
from wildfire_agent.pairwise import (
    NEAREST_PEERS,
    nearest_others,
    other_indices,
    pairwise_states,
    peer_count,
)
from wildfire_learning.vec_policies import others_of
from wildfire_msgs_py.map_geometry import MapGeometry
from wildfire_sim.landscape import Landscape
from wildfire_world.env import EnvConfig, draw_scenario


def fleet(n: int, seed: int = 0, batch: tuple[int, ...] = ()) -> AircraftState:
    rng = np.random.default_rng(seed)
    shape = (*batch, n)
    return AircraftState(
        x_m=rng.uniform(0, 5000, shape),
        y_m=rng.uniform(0, 5000, shape),
        heading_rad=rng.uniform(-np.pi, np.pi, shape),
        bank_steps=rng.integers(-10, 11, shape),
    )


def test_small_fleets_see_every_peer_as_before() -> None:
    state = fleet(NEAREST_PEERS + 1, batch=(3,))
    assert (nearest_others(state) == other_indices(NEAREST_PEERS + 1)).all()
    assert pairwise_states(state).shape == (3, 9, 8, 5) and peer_count(1) == 1


def test_large_fleets_see_their_nearest_peers() -> None:
    state = fleet(20, seed=2, batch=(2,))
    chosen = nearest_others(state)
    assert chosen.shape == (2, 20, NEAREST_PEERS) and peer_count(20) == NEAREST_PEERS
    raw = pairwise_states(state)
    for env in range(2):
        for own in range(20):
            distance = np.hypot(
                state.x_m[env] - state.x_m[env, own], state.y_m[env] - state.y_m[env, own]
            )
            distance[own] = np.inf
            expected = np.sort(np.argsort(distance, kind="stable")[:NEAREST_PEERS])
            assert (chosen[env, own] == expected).all()
            np.testing.assert_allclose(raw[env, own, :, 1], distance[expected])
    # The planner's peers are the same ones (here every aircraft knows the true poses).
    views = AircraftState(*(np.broadcast_to(f[:, None, :], (2, 20, 20)) for f in state))
    peers = others_of(views)
    assert (peers.x_m.reshape(2, 20, -1) == np.take_along_axis(
        state.x_m[:, None, :].repeat(20, 1), chosen, axis=-1)).all()  # fmt: skip


def test_starts_spread_over_the_fires() -> None:
    geometry = MapGeometry(600, 600)
    config = EnvConfig(n_aircraft=8, geometry=geometry, landscape=Landscape(geometry, ignitions=4))
    scenario = draw_scenario(7, config)
    from scipy import ndimage

    labels, count = ndimage.label(scenario.masks.ignition, structure=np.ones((3, 3), bool))
    ignition = scenario.masks.ignition
    rows_cols = np.asarray(ndimage.center_of_mass(ignition, labels, range(1, count + 1)))
    centres = (rows_cols[:, ::-1] + 0.5) * 10.0
    start = np.stack([scenario.start.x_m, scenario.start.y_m], axis=1)
    distance = np.linalg.norm(start[:, None] - centres[None], axis=-1)
    assert count == 4
    assert (distance[np.arange(8), np.arange(8) % 4] <= 300.0 + 1e-9).all()


def test_eval_flies_32_aircraft_on_a_10_km_map() -> None:
    code = "import sys; from wildfire_cli import main; sys.exit(main(sys.argv[1:]))"
    done = subprocess.run(
        [sys.executable, "-c", code, "eval", "--policy", "rh", "--aircraft", "32",
         "--map-size", "1000,1000", "--ignitions", "4", "--episodes", "1", "--duration", "3",
         "--json"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["aircraft"] == 32 and summary["map_size"] == [1000, 1000]
    assert summary["ignitions"] == 4 and summary["score_mean"] > 0


def test_the_oracle_says_where_it_stops() -> None:
    code = "import sys; from wildfire_cli import main; sys.exit(main(sys.argv[1:]))"
    done = subprocess.run(
        [sys.executable, "-c", code, "eval", "--policy", "oracle", "--map-size", "300,300"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2 and "affordable up to 40,000 cells" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
