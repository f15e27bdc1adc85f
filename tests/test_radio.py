"""Radio links: the model's grammar, the replicas' merge, heard poses and the environment."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wildfire_agent import dynamics
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.heard_poses import HeardPoses, coast
from wildfire_belief.radio import (
    DRAW_BLOCK,
    CommError,
    CommModel,
    LinkDraws,
    delivered,
    link_draws,
)
from wildfire_belief.replicas import BeliefReplicas, visit_key
from wildfire_sim.grid import MapGeometry
from wildfire_world.env import EnvConfig, WildfireVecEnv


@pytest.mark.parametrize(
    ("text", "canonical"),
    [
        ("ideal", "ideal"),
        ("none", "none"),
        ("range=300,loss=0.2", "range=300,loss=0.2"),
        ("loss=0.2, range=300", "range=300,loss=0.2"),
        ("range=150,delay=3", "range=150,delay=3"),
        ("range=inf", "ideal"),
    ],
)
def test_a_model_reads_back_from_its_canonical_text(text: str, canonical: str) -> None:
    model = CommModel.parse(text)
    assert str(model) == canonical
    assert CommModel.parse(str(model)) == model


@pytest.mark.parametrize(
    ("text", "names"),
    [
        ("range=-5", "range expected >= 0"),
        ("loss=1.5", "loss expected in [0, 1]"),
        ("loss=-0.1", "loss expected in [0, 1]"),
        ("delay=-1", "delay expected"),
        ("power=3", "keys range, loss, delay"),
        ("range", "keys range, loss, delay"),
        ("range=1,range=2", "range given twice"),
        ("range=far", "expected range in metres"),
        ("delay=0.5", "whole number of decisions"),
    ],
)
def test_a_malformed_model_is_refused_with_what_was_expected(text: str, names: str) -> None:
    with pytest.raises(CommError, match=names.replace("[", r"\[").replace("]", r"\]")):
        CommModel.parse(text)


Visit = tuple[int, int, np.ndarray, np.ndarray]


def random_visits(rng: np.random.Generator, count: int) -> list[Visit]:
    """Visits (tick, aircraft, cells, burning) of 3 aircraft over a few ticks: a visit's key
    is unique, two visits of one tick read the same truth."""
    truth = rng.random((12, 100)) < 0.3  # (tick, cell)
    visits = []
    for _ in range(count):
        tick, aircraft = int(rng.integers(1, 12)), int(rng.integers(3))
        cells = np.unique(rng.integers(0, 100, size=25))
        visits.append((tick, aircraft, cells, truth[tick, cells]))
    # One visit per key: the same aircraft and tick cannot report two different looks.
    unique = {(t, k): (t, k, c, b) for t, k, c, b in visits}
    return list(unique.values())


def merged(batches: list[list[Visit]]) -> BeliefReplicas:
    replicas = BeliefReplicas(1, 1, MapGeometry(10, 10))
    replicas.reset([0], np.zeros((1, 10, 10), dtype=bool))
    for batch in batches:
        if not batch:
            continue
        cells = np.concatenate([c for _, _, c, _ in batch])
        keys = np.concatenate([np.full(c.size, visit_key(t, k)) for t, k, c, _ in batch])
        burning = np.concatenate([b for _, _, _, b in batch])
        zeros = np.zeros(cells.size, dtype=np.int64)
        replicas.merge(zeros, zeros, cells, keys, burning)
    return replicas


@pytest.mark.parametrize("trial", range(20))
def test_shuffled_duplicated_and_delayed_visit_streams_give_equal_replicas(trial: int) -> None:
    rng = np.random.default_rng(trial)
    visits = random_visits(rng, 30)
    in_order = merged([[v] for v in sorted(visits, key=lambda v: (v[0], v[1]))])
    # Another order, every visit heard twice or three times, in batches of any size (a batch
    # is what one decision merges: a delayed visit lands in a later batch).
    stream = [visits[i] for i in rng.permutation(len(visits))]
    stream += [visits[i] for i in rng.integers(0, len(visits), size=2 * len(visits))]
    stream = [stream[i] for i in rng.permutation(len(stream))]
    cuts = np.sort(rng.integers(0, len(stream), size=5))
    batches = [list(part) for part in np.split(np.array(stream, dtype=object), cuts)]
    shuffled = merged(batches)
    assert np.array_equal(shuffled.burning, in_order.burning)
    assert np.array_equal(shuffled.key, in_order.key)


def test_the_newest_visit_of_a_cell_wins_and_ties_order_by_aircraft() -> None:
    replicas = BeliefReplicas(1, 2, MapGeometry(4, 4))
    replicas.reset([0], np.zeros((1, 4, 4), dtype=bool))
    zero, cell = np.zeros(1, dtype=np.int64), np.array([7])
    # Replica 0 hears tick 5 (burning) before tick 3 (not burning): tick 5 stays.
    replicas.merge(zero, zero, cell, visit_key(np.array([5]), 1), np.array([True]))
    replicas.merge(zero, zero, cell, visit_key(np.array([3]), 0), np.array([False]))
    assert replicas.burning[0, 0].reshape(-1)[7]
    assert replicas.last_visit()[0, 0].reshape(-1)[7] == 5
    # Replica 1 is untouched, its ages at the cap.
    assert not replicas.burning[0, 1].any()
    replicas.now[0] = 8
    assert replicas.age_s()[0, 0].reshape(-1)[7] == pytest.approx(0.3)
    assert replicas.age_s()[0, 1].max() == 255.0


def test_link_draws_depend_on_seed_link_and_tick_only() -> None:
    draws = LinkDraws(3, 3)
    ticks = np.array([DRAW_BLOCK - 1, DRAW_BLOCK, 5])
    batch = draws.at(np.array([11, 11, 12]), ticks)
    alone = LinkDraws(1, 3)
    for e, (seed, tick) in enumerate([(11, DRAW_BLOCK - 1), (11, DRAW_BLOCK), (12, 5)]):
        single = alone.at(np.array([seed]), np.array([tick]))[0]
        assert np.array_equal(batch[e], single)
        block, offset = divmod(tick, DRAW_BLOCK)
        assert single[2, 0] == link_draws(seed, 2, 0, block)[offset]
    assert batch[0, 0, 1] != batch[0, 1, 0]  # each direction of a link draws its own


def test_messages_arrive_within_range_unless_lost_and_never_to_the_sender() -> None:
    x, tick = np.array([[0.0, 250.0, 500.0]]), np.array([7])
    y = np.zeros((1, 3))
    draws = np.full((1, 3, 3), 0.5)
    draws[0, 0, 1] = 0.1  # the 0 -> 1 message is lost at loss 0.2
    reach = delivered(CommModel.parse("range=300,loss=0.2"), draws, x, y, tick)[0]
    assert not reach[0, 1] and reach[1, 0]
    assert reach[1, 2] and reach[2, 1]  # 250 m apart
    assert not reach[0, 2] and not reach[2, 0]  # 500 m apart: out of range
    assert not reach.diagonal().any()
    assert not delivered(CommModel.parse("none"), draws, x, y, tick).any()
    everything = delivered(CommModel.parse("range=1e6"), draws, x, y, tick)[0]
    assert np.array_equal(everything, ~np.eye(3, dtype=bool))


def test_coasting_flies_the_constant_bank_arc_and_zero_decisions_change_nothing() -> None:
    start = AircraftState(
        np.array([100.0, 500.0]),
        np.array([200.0, 50.0]),
        np.array([0.3, -2.0]),
        np.array([4, 0]),
    )
    stepped = start
    for _ in range(37):
        stepped = dynamics.propagate(stepped)
    coasted = coast(start, np.array([37, 37]))
    assert np.allclose(coasted.x_m, stepped.x_m, atol=1e-6)
    assert np.allclose(coasted.y_m, stepped.y_m, atol=1e-6)
    still = coast(start, np.array([0, 0]))
    for field, given in zip(still, start, strict=True):
        assert np.array_equal(field, given)


def test_a_peer_is_seen_where_it_was_heard_dead_reckoned_and_oneself_exactly() -> None:
    heard = HeardPoses(1, 2, 2)
    start = AircraftState(
        *(np.array([[a, b]]) for a, b in [(100.0, 400.0), (100.0, 100.0), (0.0, 1.0), (0, -3)])
    )
    start = start._replace(bank_steps=start.bank_steps.astype(np.int64))
    heard.reset(np.array([0]), start)
    own = AircraftState(*(np.array([[1.0, 2.0]]) for _ in range(3)), np.array([[1, 2]]))
    team = heard.team(np.array([10]), own, np.arange(2))
    expected = coast(AircraftState(*(f[0, 1] for f in start)), np.array(10))
    assert team.x_m[0, 0, 1] == expected.x_m and team.bank_steps[0, 0, 1] == -3
    assert team.x_m[0, 0, 0] == 1.0 and team.bank_steps[0, 1, 1] == 2


def run_env(
    comm: str, seeds: list[int], decisions: int, geometry: MapGeometry | None = None
) -> tuple[WildfireVecEnv, list[dict]]:
    config = EnvConfig(
        observation="belief",
        reward="belief",
        comm=CommModel.parse(comm),
        **({"geometry": geometry} if geometry is not None else {}),
    )
    env = WildfireVecEnv(config, len(seeds))
    observations = [env.reset(seeds)]
    rng = np.random.default_rng(7)
    for _ in range(decisions):
        observations.append(env.step(rng.integers(0, 2, size=(len(seeds), 2))).observations)
    return env, observations


def test_perfect_links_through_the_replicas_give_the_shared_belief_bit_for_bit() -> None:
    ideal, seen_ideal = run_env("ideal", [3, 4], 120)
    perfect, seen_perfect = run_env("range=1e9", [3, 4], 120)
    assert ideal.radio is None and perfect.radio is not None
    for a, b in zip(seen_ideal, seen_perfect, strict=True):
        assert np.array_equal(a["image"], b["image"])
        assert np.array_equal(a["state"], b["state"])
    assert np.array_equal(ideal.scores, perfect.scores)


def test_without_links_each_aircraft_knows_its_own_visits_and_the_score_is_the_union() -> None:
    ideal, _ = run_env("ideal", [3], 200)
    alone, last = run_env("none", [3], 200)
    assert np.array_equal(alone.scores, ideal.scores)  # same flights: the union is the same
    assert alone.radio is not None
    replicas = alone.radio.replicas
    union = ideal.belief.last_visit[0] >= 0
    mine = [replicas.last_visit()[0, k] >= 0 for k in range(2)]
    assert np.array_equal(mine[0] | mine[1], union)
    assert not np.array_equal(mine[0], mine[1])
    assert not np.array_equal(last[-1]["image"][0, 0], last[-1]["image"][0, 1])
    # Aircraft 0 never heard aircraft 1: it believes 1 coasts on from its start pose.
    team = alone.team_views()
    start = AircraftState(*(f[0, 0, 1] for f in alone.radio.heard.pose))
    expected = coast(start, np.array(200))
    assert team.x_m[0, 0, 1] == expected.x_m
    assert not math.isclose(team.x_m[0, 0, 1], alone.aircraft.x_m[0, 1])


def test_episodes_that_end_early_leave_the_others_flying_under_the_radio() -> None:
    """A batch whose episodes end at different ticks (the evaluation's case)."""
    config = EnvConfig(observation="belief", reward="belief", comm=CommModel.parse("none"))
    env = WildfireVecEnv(config, 3)
    env.reset([3, 4, 5])
    env.done[1] = True
    rng = np.random.default_rng(1)
    for _ in range(30):
        env.step(rng.integers(0, 2, size=(3, 2)))
    assert env.radio is not None
    assert list(env.radio.replicas.now) == [30, 0, 30]


def test_a_radio_message_is_under_a_hundred_bytes_and_reads_back() -> None:
    from wildfire_agent.aircraft_radio import AircraftRadio, window_of
    from wildfire_agent.aircraft_sensor import visit_window
    from wildfire_msgs_py.radio_codec import radio_from_msg, radio_to_msg

    burning = np.zeros((100, 100), dtype=bool)
    burning[40:60, 45:55] = True
    state = AircraftState(np.array([503.0]), np.array([455.5]), np.array([0.4]), np.array([-3]))
    window = visit_window(state, burning)
    radio = AircraftRadio(CommModel.parse("range=300"), 1, 2, 5, burning)
    message = radio.message(7, state, window)
    msg = radio_to_msg(message)
    assert len(msg.data) <= 100 - 16  # plus 16 bytes of CDR framing on the wire
    back = radio_from_msg(msg)
    assert (back.tick, back.aircraft, back.bank_steps) == (7, 1, -3)
    assert (back.x_m, back.y_m, back.heading_rad) == (503.0, 455.5, 0.4)
    heard = window_of(back)
    assert np.array_equal(heard.visited, window.visited)
    assert np.array_equal(heard.burning, window.burning)


def test_radio_messages_that_lie_are_dropped_with_their_reason() -> None:
    from wildfire_agent.aircraft_radio import AircraftRadio, window_of
    from wildfire_agent.aircraft_sensor import visit_window
    from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
    from wildfire_msgs_py.radio_codec import radio_to_msg
    from wildfire_msgs_py.wire_checks import checked_radio

    burning = np.ones((100, 100), dtype=bool)
    state = AircraftState(np.array([500.0]), np.array([500.0]), np.array([0.0]), np.array([0]))
    message = AircraftRadio(CommModel.parse("none"), 1, 2, 5, burning).message(
        3, state, visit_window(state, burning)
    )
    assert checked_radio(radio_to_msg(message), 1, 10)[0] == 3 * 100_000_000
    lies = {
        DropReason.IMPERSONATION: (radio_to_msg(message), 0),
        DropReason.OUT_OF_RANGE: (radio_to_msg(message._replace(x_m=float("nan"))), 1),
    }
    for reason, (msg, sender) in lies.items():
        with pytest.raises(RejectedMessage) as error:
            checked_radio(msg, sender, 10)
        assert error.value.reason is reason
    for lie in (message._replace(x_m=5.0), message._replace(bits=message.bits[:-1])):
        with pytest.raises(RejectedMessage) as error:
            window_of(lie)
        assert error.value.reason is DropReason.MALFORMED


def test_after_an_outage_the_catch_up_restores_the_shared_belief_in_every_replica() -> None:
    """Perfect links but a 6 s outage: each replica misses the other's visits, then the
    digest-and-reply exchange brings both back to the union of every visit, bit for bit."""
    ideal, _ = run_env("ideal", [3, 4], 140)
    cut, _ = run_env("range=1e9,outage=2-8", [3, 4], 140)
    assert cut.radio is not None
    union_age = ideal.belief.age_s()
    replicas = cut.radio.replicas
    for k in range(2):
        assert np.array_equal(replicas.burning[:, k], ideal.belief.burning)
        assert np.array_equal(replicas.age_s()[:, k], union_age)
    # Stopped just after the outage, before any reply is heard, they differ.
    early, _ = run_env("range=1e9,outage=2-8", [3, 4], 81)
    assert early.radio is not None
    assert not np.array_equal(early.radio.replicas.key[:, 0], early.radio.replicas.key[:, 1])


def test_on_an_oblong_field_map_the_catch_up_restores_every_cell() -> None:
    """A map of 78 000 cells (more than 16-bit cell indices hold) and not square: digests
    keep 100 blocks, replies name every cell, and the replicas end as the union again."""
    field = MapGeometry(300, 260)
    ideal, _ = run_env("ideal", [5], 140, field)
    cut, _ = run_env("range=1e9,outage=2-8", [5], 140, field)
    assert cut.radio is not None
    for k in range(2):
        assert np.array_equal(cut.radio.replicas.burning[:, k], ideal.belief.burning)
        assert np.array_equal(cut.radio.replicas.age_s()[:, k], ideal.belief.age_s())


def test_a_field_maps_digest_and_reply_travel_whole() -> None:
    from wildfire_belief.catch_up import digest_of, make_reply, missing_visits
    from wildfire_msgs_py.radio_codec import Digest, RadioMessage, radio_from_bytes, radio_to_bytes

    rng = np.random.default_rng(4)
    key = visit_key(rng.integers(0, 3000, (1000, 730)), rng.integers(0, 3, (1000, 730)))
    burning = rng.random((1000, 730)) < 0.5
    digest = digest_of(key)
    assert digest.shape == (100,)
    # Every block is the oldest last visit of its band of 100 x 73 (or 72) cells.
    assert digest[0] == (key[:100, :73] >> 6).min() and digest[99] == (key[900:, 657:] >> 6).min()
    older = np.zeros(100, dtype=np.uint16)
    reply = make_reply(2, key, burning, older)
    cells, _, _ = missing_visits(key, burning, older, 2)
    assert reply.cells.size == cells.size and int(reply.cells.max()) > 2**16
    message = RadioMessage(
        9, 1, 1.0, 2.0, 0.0, 0, np.zeros(3, np.uint8), (Digest(0, digest),), (reply,)
    )
    back = radio_from_bytes(radio_to_bytes(message))
    assert np.array_equal(back.digests[0].block_ticks, digest)
    assert np.array_equal(back.replies[0].cells, reply.cells)
    assert np.array_equal(back.replies[0].ticks, reply.ticks)
    assert np.array_equal(back.bits, message.bits)


def test_catch_up_sections_read_back_and_a_reply_that_lies_is_malformed() -> None:
    from wildfire_belief.catch_up import digest_of, make_reply
    from wildfire_msgs_py.errors import MessageFieldError
    from wildfire_msgs_py.radio_codec import Digest, RadioMessage, radio_from_bytes, radio_to_bytes

    rng = np.random.default_rng(3)
    replica = BeliefReplicas(1, 1)
    cells = rng.choice(10_000, size=700, replace=False)
    replica.merge(
        np.zeros(700, np.int64), np.zeros(700, np.int64), cells,
        visit_key(rng.integers(1, 400, size=700), rng.integers(0, 3, size=700)),
        rng.random(700) < 0.5,
    )  # fmt: skip
    key, burning = replica.key[0, 0], replica.burning[0, 0]
    reply = make_reply(5, key, burning, np.zeros(100, dtype=np.uint16))
    assert reply.cells.size == 700
    digest = Digest(0, digest_of(key))
    message = RadioMessage(400, 1, 1.0, 2.0, 0.5, 0, np.zeros(3, np.uint8), (digest,), (reply,))
    data = radio_to_bytes(message)
    assert len(data) < 700 * 7  # compressed
    decoded = radio_from_bytes(data)
    assert decoded.digests[0].target == 0
    assert np.array_equal(decoded.digests[0].block_ticks, digest.block_ticks)
    back = decoded.replies[0]
    for field in ("cells", "ticks", "aircraft", "burning"):
        assert np.array_equal(getattr(back, field), getattr(reply, field))
    assert np.array_equal(decoded.bits, message.bits)
    with pytest.raises(MessageFieldError):
        radio_from_bytes(data[:-5] + b"\x00" * 5)
