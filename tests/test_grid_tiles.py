"""The fuel map on the wire: whole now and then, changed tiles between; a receiver rebuilds it
exactly in any order of arrival, and tiles off the tile grid or of the wrong size are refused."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_msgs_py.codecs import fuel_grid_to_msg, grid_to_msg, time_from_msg
from wildfire_msgs_py.grid_tiles import (
    TILE,
    WHOLE_EVERY_STEPS,
    TiledMap,
    changed_tiles,
    tile_to_msg,
)
from wildfire_msgs_py.input_guard import RejectedMessage
from wildfire_msgs_py.map_geometry import MapGeometry
from wildfire_msgs_py.wire_checks import checked_fuel_grid, checked_fuel_tile
from wildfire_ros.runtime import deserialize_message, serialize_message
from wildfire_sim.episode import FireEpisode, Mode
from wildfire_sim.fire_protocol import FireProtocol
from wildfire_sim.landscape import Landscape

pytestmark = pytest.mark.dds  # messages of the active backend, over its wire format

FIELD = MapGeometry(150, 210)  # neither side a multiple of the tile


def _wire(msg: object) -> object:
    return deserialize_message(serialize_message(msg), type(msg))


def test_the_fire_simulators_fuel_rebuilds_exactly_in_any_order() -> None:
    episode = FireEpisode(
        3,
        "circular",
        (0.4, 0.1),
        max_decisions=(WHOLE_EVERY_STEPS + 12) * 25,
        preburn_steps=0,
        ground=Landscape(FIELD, ignitions=3),
    )
    protocol = FireProtocol(episode, Mode.LOCKSTEP, ["uav0"])
    sent, truth = [], {}
    outs = [protocol.maps()]
    while not episode.final:
        if episode.advance():
            outs.append(protocol.maps())
    for out in outs:
        truth[out.stamp] = out.fuel
        if out.fuel_tiles is None:
            sent.append(("whole", _wire(fuel_grid_to_msg(out.fuel, out.stamp))))
        else:
            # Tiles where the fire burns, not the map.
            assert len(out.fuel_tiles) < (FIELD.rows // TILE) * (FIELD.cols // TILE)
            sent += [("tile", _wire(tile_to_msg(tile))) for tile in out.fuel_tiles]
    wholes = [out.stamp for out in outs if out.fuel_tiles is None]
    assert wholes == [outs[0].stamp, outs[WHOLE_EVERY_STEPS].stamp]
    # In order, the map of every fire step; in any order, the last one.
    received = TiledMap()
    for out_index, out in enumerate(outs):
        for kind, msg in sent:
            if time_from_msg(msg.header.stamp) != out.stamp:  # type: ignore[attr-defined]
                continue
            if kind == "whole":
                received.on_whole(*checked_fuel_grid(msg, FIELD))
            else:
                received.on_tile(checked_fuel_tile(msg, FIELD))
        np.testing.assert_array_equal(received.grid, out.fuel, err_msg=f"step {out_index}")
    for order in (1, 2):
        shuffled = TiledMap()
        for index in np.random.default_rng(order).permutation(len(sent)):
            kind, msg = sent[index]
            if kind == "whole":
                shuffled.on_whole(*checked_fuel_grid(msg, FIELD))
            else:
                shuffled.on_tile(checked_fuel_tile(msg, FIELD))
        np.testing.assert_array_equal(shuffled.grid, outs[-1].fuel)


def test_changed_tiles_cover_every_change_and_only_their_tiles() -> None:
    rng = np.random.default_rng(0)
    old = rng.integers(0, 20, FIELD.shape).astype(np.int8)
    new = old.copy()
    new[3, 5] = 0
    new[149, 209] = 0  # in the last, cut tile
    tiles = changed_tiles(7, old, new)
    assert [(t.row0, t.col0) for t in tiles] == [(0, 0), (128, 192)]
    assert tiles[1].values.shape == (150 - 128, 210 - 192)
    assert changed_tiles(7, new, new) == []


@pytest.mark.parametrize(
    ("origin", "shape", "why"),
    [
        ((5.0, 0.0), (TILE, TILE), "off the tile grid"),
        ((0.0, 320.0 * 5), (TILE, TILE), "off the tile grid"),  # north of the map
        ((320.0, 0.0), (TILE, TILE + 1), "tile"),
        ((320.0 * 6, 0.0), (TILE, TILE), "tile"),  # the last column of tiles is 18 wide
        ((float("nan"), 0.0), (TILE, TILE), "off the tile grid"),
    ],
)
def test_a_wrong_tile_is_refused(
    origin: tuple[float, float], shape: tuple[int, int], why: str
) -> None:
    good = _wire(grid_to_msg(np.full((TILE, TILE), 7), 5, origin_xy=(320.0, 320.0)))
    assert checked_fuel_tile(good, FIELD).row0 == TILE
    bad = _wire(grid_to_msg(np.full(shape, 7), 5, origin_xy=origin))
    with pytest.raises(RejectedMessage, match=why):
        checked_fuel_tile(bad, FIELD)
