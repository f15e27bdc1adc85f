"""Filtered replicas: noisy reports under limited radio links (the replay, the environment)."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_belief.filtered_belief import LogOddsBelief
from wildfire_belief.filtered_replicas import FilteredReplicas, fire_step_at
from wildfire_belief.radio import CommModel
from wildfire_sim.episode import DECISIONS_PER_FIRE_STEP
from wildfire_sim.grid import MapGeometry
from wildfire_world.config import WorldError
from wildfire_world.env import EnvConfig, WildfireVecEnv

GEOMETRY = MapGeometry(40, 50)
TICKS = 130  # five fire steps
SENDERS = 3


def report_stream(rng: np.random.Generator) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
    """Reports (tick, sender, cells, values) of every tick: a patch of cells per sender,
    some seen twice (overlapping cameras), mostly burning near the centre."""
    stream = []
    for tick in range(1, TICKS + 1):
        for sender in range(SENDERS):
            cells = rng.integers(0, GEOMETRY.cells, size=int(rng.integers(0, 60)))
            cells = np.concatenate([cells, cells[: cells.size // 4]])
            values = rng.random(cells.size) < 0.4
            stream.append((tick, sender, cells, values))
    return stream


def start(replicas: FilteredReplicas) -> None:
    ignition = np.zeros((1, *GEOMETRY.shape), dtype=bool)
    ignition[0, 18:22, 23:27] = True
    replicas.reset([0], ignition, np.ones_like(ignition), preburn_steps=3)


def fly(
    replicas: FilteredReplicas,
    arrivals: dict[int, list[tuple[int, int, int, np.ndarray, np.ndarray]]],
    last: int,
) -> None:
    """Tick by tick to ``last``: each tick's arrivals (replica, tick, sender, cells, values)
    held in the order given, then settled."""
    for now in range(1, last + 1):
        replicas.tick(np.array([0]), np.array([fire_step_at(now)]))
        for replica, tick, sender, cells, values in arrivals.get(now, []):
            replicas.hold(0, replica, sender, tick, cells, values)
        replicas.settle()


def state(replicas: FilteredReplicas, r: int) -> tuple[np.ndarray, ...]:
    belief = replicas.belief
    return belief.log_odds[r], belief.spent[r], belief.burn_age[r], belief.last_report[r]


@pytest.mark.parametrize("trial", range(6))
def test_shuffled_duplicated_and_delayed_report_streams_give_the_filter_in_tick_order(
    trial: int,
) -> None:
    """Replica 0 hears every report at its tick; replica 1 the same reports up to 40 ticks
    late (across fire steps), shuffled, some twice. Both equal the plain filter run in tick
    order over every report, bit for bit."""
    rng = np.random.default_rng(trial)
    stream = report_stream(rng)
    replicas = FilteredReplicas(1, 2, 0.1, GEOMETRY, window_ticks=100)
    start(replicas)
    arrivals: dict[int, list] = {}
    for tick, sender, cells, values in stream:
        arrivals.setdefault(tick, []).append((0, tick, sender, cells, values))
        for _ in range(1 + int(rng.random() < 0.3)):
            late = tick + int(rng.integers(0, 41))
            arrivals.setdefault(min(late, TICKS), []).append((1, tick, sender, cells, values))
    for batch in arrivals.values():
        rng.shuffle(batch)  # type: ignore[arg-type]
    fly(replicas, arrivals, TICKS)

    plain = LogOddsBelief(1, 0.1, geometry=GEOMETRY)
    ignition = np.zeros((1, *GEOMETRY.shape), dtype=bool)
    ignition[0, 18:22, 23:27] = True
    plain.reset([0], ignition, np.ones_like(ignition), 3)
    for now in range(1, TICKS + 1):
        plain.tick([0])
        if fire_step_at(now):
            plain.predict([0])
        mine = [(c, v) for t, _, c, v in stream if t == now]
        cells = np.concatenate([c for c, _ in mine])
        plain.update(np.zeros(cells.size, np.int64), cells, np.concatenate([v for _, v in mine]))
    expected = (plain.log_odds[0], plain.spent[0], plain.burn_age[0], plain.last_report[0])
    for r in range(2):
        for got, want in zip(state(replicas, r), expected, strict=True):
            assert np.array_equal(got, want)
    assert replicas.too_old.sum() == 0
    # A catch-up reply of replica 0 to replica 1 holds nothing new; an empty one neither.
    assert replicas.hold_reply(0, 1, replicas.reply(0, 0, 1, replicas.digest(0, 1))) == 0
    assert replicas.hold_reply(0, 1, replicas.reply(0, 0, 1, np.full(100, 65535))) == 0


def test_a_report_older_than_the_window_is_dropped_and_counted() -> None:
    rng = np.random.default_rng(3)
    stream = [r for r in report_stream(rng) if r[0] <= 10]
    replicas = FilteredReplicas(1, 2, 0.1, GEOMETRY, window_ticks=50)
    start(replicas)
    tick, sender, cells, values = stream[0]
    fly(replicas, {}, 100)
    before = [a.copy() for a in state(replicas, 1)]
    assert not replicas.hold(0, 1, sender, tick, cells, values)
    assert not replicas.hold(0, 1, sender, 101, cells, values)  # a tick not flown yet
    replicas.settle()
    assert replicas.too_old[1] == 1
    for got, want in zip(state(replicas, 1), before, strict=True):
        assert np.array_equal(got, want)


def camera_env(comm: str, seeds: list[int], decisions: int) -> WildfireVecEnv:
    config = EnvConfig(
        n_aircraft=3,
        observation="belief",
        sensor="camera",
        pixel_error=0.1,
        comm=CommModel.parse(comm),
    )
    env = WildfireVecEnv(config, len(seeds))
    env.reset(seeds)
    rng = np.random.default_rng(11)
    for _ in range(decisions):
        observation = env.step(rng.integers(0, 2, size=(len(seeds), 3))).observations
    env.last_images = observation["image"]  # type: ignore[attr-defined]
    return env


def replica_log_odds(env: WildfireVecEnv) -> np.ndarray:
    assert env.radio is not None
    return env.radio.replicas.belief.log_odds.reshape(env.num_envs, 3, *env.geometry.shape)


def test_perfect_links_give_every_replica_the_team_filtered_belief_bit_for_bit() -> None:
    ideal = camera_env("ideal", [5, 6], 120)
    perfect = camera_env("range=1e9", [5, 6], 120)
    team = ideal.sensing
    assert team is not None
    for k in range(3):
        assert np.array_equal(replica_log_odds(perfect)[:, k], team.belief.log_odds)
    assert np.array_equal(ideal.last_images, perfect.last_images)  # type: ignore[attr-defined]
    assert np.array_equal(ideal.scores, perfect.scores)


def test_after_an_outage_the_catch_up_makes_the_replicas_equal_bit_for_bit() -> None:
    """A 5 s outage of the whole team: each replica misses the others' reports; the
    digests and replies bring every replica back to the team's filtered belief."""
    cut = camera_env("range=1e9,outage=3-8", [5, 6], 140)
    team = cut.sensing
    assert team is not None and cut.radio is not None
    for k in range(3):
        assert np.array_equal(replica_log_odds(cut)[:, k], team.belief.log_odds)
    assert cut.radio.replicas.too_old.sum() == 0
    early = camera_env("range=1e9,outage=3-8", [5, 6], 81)
    assert not np.array_equal(replica_log_odds(early)[:, 0], replica_log_odds(early)[:, 1])


def test_under_lossy_short_links_each_aircraft_decides_on_its_own_replica() -> None:
    env = camera_env("range=300,loss=0.2", [5], 150)
    images = env.last_images  # type: ignore[attr-defined]
    replicas = replica_log_odds(env)
    assert not np.array_equal(replicas[:, 0], replicas[:, 1])
    # The score is the team's filtered belief of every report, whatever was heard.
    assert np.array_equal(env.scores, camera_env("ideal", [5], 150).scores)
    assert images.shape == (1, 3, 2, 100, 100)


def test_the_wind_filter_under_limited_links_is_refused_with_its_reason() -> None:
    config = EnvConfig(
        sensor="camera", pixel_error=0.1, wind_filter=True, comm=CommModel.parse("range=300")
    )
    with pytest.raises(WorldError, match="--comm ideal"):
        config.validate()


def test_episodes_on_their_own_clocks_replay_as_alone() -> None:
    """A batch whose second episode restarts a fire step after the first (training restarts
    each episode when it ends): their fire steps fall on the same calls at different ticks,
    and each replays late reports as it would alone."""
    rng = np.random.default_rng(5)
    stream = report_stream(rng)
    batch, alone = FilteredReplicas(2, 1, 0.1, GEOMETRY), FilteredReplicas(1, 1, 0.1, GEOMETRY)
    start(alone)
    start(batch)

    def arrive(replicas: FilteredReplicas, env: int, clock: int) -> None:
        for tick, sender, cells, values in stream:
            # Late within a fire step's interval: the replay starts at the checkpoint that
            # tick() made, never at one a replay made.
            late = 7 if sender == 1 and 1 <= tick % DECISIONS_PER_FIRE_STEP <= 17 else 0
            if tick + late == clock:
                replicas.hold(env, 0, sender, tick, cells, values)

    for now in range(1, TICKS + 1):
        alone.tick(np.array([0]), np.array([fire_step_at(now)]))
        arrive(alone, 0, now)
        alone.settle()
    for now in range(1, TICKS + 26):
        if now == 26:
            ignition = np.zeros((1, *GEOMETRY.shape), dtype=bool)
            ignition[0, 18:22, 23:27] = True
            batch.reset([1], ignition, np.ones_like(ignition), preburn_steps=3)
        episodes = [0] if now <= 25 else [0, 1]
        clocks = {0: now, 1: now - 25}
        batch.tick(np.array(episodes), np.array([fire_step_at(clocks[e]) for e in episodes]))
        for e in episodes:
            arrive(batch, e, clocks[e])
        batch.settle()
    assert np.array_equal(batch.belief.log_odds[1], alone.belief.log_odds[0])
    assert np.array_equal(batch.belief.burn_age[1], alone.belief.burn_age[0])
