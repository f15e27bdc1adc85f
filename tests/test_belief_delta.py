"""The shared belief as keyframes and deltas: every tick rebuilt bit for bit, in any order of
arrival, through the wire of the active backend; deltas that lie are refused."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_belief.aggregator import BeliefAggregator
from wildfire_msgs_py.belief_codec import belief_grid
from wildfire_msgs_py.belief_delta import (
    AGE_CAP_TICKS,
    KEYFRAME_TICKS,
    BeliefDelta,
    BeliefMirror,
    DeltaEncoder,
    Frame,
    delta_to_msg,
)
from wildfire_msgs_py.codecs import VisitWindow, grid_to_msg
from wildfire_msgs_py.input_guard import RejectedMessage
from wildfire_msgs_py.map_geometry import MapGeometry
from wildfire_msgs_py.system_codecs import age_image_to_msg
from wildfire_msgs_py.wire_checks import (
    checked_age_image,
    checked_belief_delta,
    checked_belief_values,
)
from wildfire_ros.runtime import deserialize_message, serialize_message

pytestmark = pytest.mark.dds  # messages of the active backend, over its wire format

FIELD = MapGeometry(120, 160)


def _wire(msg: object) -> object:
    return deserialize_message(serialize_message(msg), type(msg))


def _flight(ticks: int, seed: int) -> list[Frame]:
    """The shared belief of every tick of a random flight of three aircraft on ``FIELD``."""
    rng = np.random.default_rng(seed)
    ignition = np.zeros(FIELD.shape, dtype=bool)
    ignition[50:60, 70:80] = True
    aggregator = BeliefAggregator(ignition)
    truth = rng.random(FIELD.shape) < 0.2
    frames = [Frame(0, belief_grid(aggregator.burning), aggregator.age_s())]
    for tick in range(1, ticks):
        windows = []
        for _ in range(3):
            row0, col0 = int(rng.integers(-10, 110)), int(rng.integers(-10, 150))
            visited = rng.random((21, 21)) < 0.7
            rows, cols = np.ogrid[row0 : row0 + 21, col0 : col0 + 21]
            seen = truth[np.clip(rows, 0, 119), np.clip(cols, 0, 159)]
            inside = FIELD.inside(rows, cols)
            windows.append(VisitWindow(row0, col0, visited & inside, seen & visited & inside))
        aggregator.merge(windows)
        stamp = tick * 100_000_000
        frames.append(Frame(stamp, belief_grid(aggregator.burning), aggregator.age_s()))
    return frames


def test_every_tick_is_rebuilt_exactly_in_any_order_of_arrival() -> None:
    frames = _flight(3 * KEYFRAME_TICKS + 7, seed=4)
    encoder = DeltaEncoder()
    messages = []
    for clock, frame in enumerate(frames):
        out = encoder.encode(frame.stamp, frame.grid, frame.age_s, clock)
        if isinstance(out, BeliefDelta):
            # A delta holds the cells its tick changed since the keyframe, not the map.
            assert out.cells.size <= 3 * 441 * out.elapsed
            messages.append(("delta", _wire(delta_to_msg(out))))
        else:
            assert clock % KEYFRAME_TICKS == 0
            messages.append(("grid", _wire(grid_to_msg(out.grid, out.stamp))))
            messages.append(("ages", _wire(age_image_to_msg(out.age_s, out.stamp))))
    for order in range(3):
        mirror, rebuilt = BeliefMirror(), {}
        shuffled = list(messages)
        if order:
            np.random.default_rng(order).shuffle(shuffled)  # type: ignore[arg-type]
        for kind, msg in shuffled:
            if kind == "grid":
                completed = mirror.on_key_grid(*checked_belief_values(msg, FIELD))
            elif kind == "ages":
                completed = mirror.on_key_ages(*checked_age_image(msg, FIELD))
            else:
                completed = mirror.on_delta(checked_belief_delta(msg, FIELD))
            for frame in completed:
                assert frame.stamp not in rebuilt
                rebuilt[frame.stamp] = frame
        assert sorted(rebuilt) == [f.stamp for f in frames]
        for frame in frames:
            np.testing.assert_array_equal(rebuilt[frame.stamp].grid, frame.grid)
            got = rebuilt[frame.stamp].age_s
            assert got.dtype == np.float32 and np.array_equal(got, frame.age_s)
    # Unvisited cells stay at the cap, and visited ones start again from 0.
    assert frames[-1].age_s.max() == AGE_CAP_TICKS / 10 and frames[-1].age_s.min() == 0.0


def _delta(**change: object) -> object:
    fields = {
        "stamp": 700_000_000,
        "key_stamp": 500_000_000,
        "elapsed": 2,
        "cells": np.array([3, 9, 161]),
        "values": np.array([100, 0, 100]),
        "ticks": np.array([0, 1, 2550]),
    } | change
    return _wire(delta_to_msg(BeliefDelta(**fields)))  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "change",
    [
        {"cells": np.array([3, 9, FIELD.cells])},  # off the map
        {"cells": np.array([3, 3, 161])},  # a cell twice
        {"cells": np.array([-1, 9, 161])},
        {"values": np.array([100, 101, 0])},
        {"ticks": np.array([0, -1, 2])},
        {"ticks": np.array([0, 1, AGE_CAP_TICKS + 1])},
        {"elapsed": 0},
        {"elapsed": KEYFRAME_TICKS},
        {"key_stamp": 800_000_000},  # a keyframe after its delta
    ],
)
def test_a_lying_delta_is_refused(change: dict[str, object]) -> None:
    checked_belief_delta(_delta(), FIELD)  # the honest one passes
    with pytest.raises(RejectedMessage):
        checked_belief_delta(_delta(**change), FIELD)


def test_a_truncated_delta_is_malformed() -> None:
    msg = _delta()
    msg.data = msg.data[:-1]  # type: ignore[attr-defined]
    with pytest.raises(Exception, match="do not hold 3 cells"):
        checked_belief_delta(msg, FIELD)


def test_the_wire_ages_are_the_beliefs() -> None:
    # The interface cannot import the belief package: its copy of the age clock must agree.
    from wildfire_belief import belief
    from wildfire_msgs_py import belief_delta

    assert belief_delta.AGE_CAP_TICKS == belief.AGE_CAP_TICKS
    assert belief_delta.TICKS_PER_S == belief.TICKS_PER_S


def test_a_belief_snapshot_of_an_oblong_map_reads_back_and_a_wrong_size_is_refused() -> None:
    """A restarted aggregator recovers from an agent's snapshot on any map, square or not."""
    from wildfire_msgs_py.system_codecs import BeliefSnapshot, snapshot_to_msg
    from wildfire_msgs_py.wire_checks import checked_snapshot

    rng = np.random.default_rng(2)
    believed = rng.random(FIELD.shape) < 0.2
    ages = rng.integers(0, 2550, FIELD.shape).astype(np.float32) / np.float32(10)
    msg = _wire(snapshot_to_msg(BeliefSnapshot(12.5, 340.0, believed, ages)))
    back = checked_snapshot(msg, FIELD)
    assert (back.time_s, back.score) == (12.5, 340.0)
    assert np.array_equal(back.believed, believed) and np.array_equal(back.age_s, ages)
    with pytest.raises(RejectedMessage):
        checked_snapshot(msg, MapGeometry(160, 120))
    with pytest.raises(RejectedMessage):
        checked_snapshot(msg, MapGeometry(100, 100))
