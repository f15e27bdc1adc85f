"""Decoders for what nodes receive: the codecs plus every check a hostile sender could fail.

The plain codecs (:mod:`wildfire_msgs_py.codecs`) read any well-formed message, e.g. from a
bag. A node must also refuse what no honest node of the system publishes: grids of another
size or resolution, fire values other than 0/100, frames other than ``map``, non-finite or
out-of-range numbers, unknown reporters. Each ``checked_*`` function returns the decoded value
or raises :class:`~wildfire_msgs_py.input_guard.RejectedMessage` naming the reason; the
node's :class:`~wildfire_msgs_py.input_guard.InputGuard` then drops and counts the message.
Stamps (stale, future, duplicate) are checked where the node's clock is known, by
:class:`~wildfire_msgs_py.input_guard.TickInbox`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wildfire_msgs_py.belief_codec import belief_probability
from wildfire_msgs_py.belief_delta import (
    AGE_CAP_TICKS,
    KEYFRAME_TICKS,
    BeliefDelta,
    delta_from_msg,
)
from wildfire_msgs_py.codecs import (
    FIRE_BURNING,
    FIRE_NOT_BURNING,
    STATE_FIELDS,
    UNKNOWN_CELL,
    VisitWindow,
    float64_from_msg,
    grid_from_msg,
    time_from_msg,
    visit_from_msg,
)
from wildfire_msgs_py.contract import DECISION_PERIOD_NS, MAP_FRAME
from wildfire_msgs_py.grid_tiles import TILE, Tile, tile_shape
from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.map_geometry import CELL_SIZE_M, PAPER_MAP, MapGeometry
from wildfire_msgs_py.radio_codec import RadioMessage, radio_from_msg
from wildfire_msgs_py.system_codecs import (
    EPISODE_NAME,
    READY_SUFFIX,
    BeliefSnapshot,
    EpisodeStatus,
    ack_from_msg,
    age_image_from_msg,
    episode_from_msg,
    snapshot_from_msg,
    stamped_state_from_msg,
)

POSITION_LIMIT_M = 100_000.0
"""No aircraft of an episode gets 100 km from the 1 km map."""
HEADING_LIMIT_RAD = 1.0e6
"""Headings are not wrapped; an honest one stays far below this after any episode."""
AGE_LIMIT_S = 1.0e6
"""Belief ages (seconds since visited) of any episode lie below this."""


def _reject(reason: DropReason, detail: str) -> RejectedMessage:
    return RejectedMessage(reason, detail)


def _stamp(header: Any) -> int:
    stamp = time_from_msg(header.stamp)
    if stamp < 0:
        raise _reject(DropReason.OUT_OF_RANGE, f"negative stamp {stamp} ns")
    return stamp


def _frame(header: Any, expected: str = MAP_FRAME) -> None:
    if header.frame_id != expected:
        raise _reject(DropReason.WRONG_FRAME, f"frame {header.frame_id!r}, expected {expected!r}")


def _grid_layout(msg: Any, shape: tuple[int, int], what: str) -> None:
    """An OccupancyGrid in frame ``map`` of ``shape`` (rows, cols) cells of the map's size."""
    _frame(msg.header)
    if (msg.info.height, msg.info.width) != shape:
        raise _reject(
            DropReason.MALFORMED,
            f"{what} {msg.info.height} x {msg.info.width}, expected {shape[0]} x {shape[1]}",
        )
    if msg.info.resolution != CELL_SIZE_M:
        raise _reject(
            DropReason.OUT_OF_RANGE, f"resolution {msg.info.resolution}, expected {CELL_SIZE_M}"
        )


def _map_grid(msg: Any, geometry: MapGeometry) -> np.ndarray:
    """The (rows, cols) grid of a map-sized OccupancyGrid in frame ``map``."""
    _grid_layout(msg, geometry.shape, "grid")
    return grid_from_msg(msg)


def checked_fire_grid(msg: Any, geometry: MapGeometry = PAPER_MAP) -> tuple[int, np.ndarray]:
    """Fire map of ``geometry`` -> (stamp ns, bool burning mask)."""
    stamp = _stamp(msg.header)
    grid = _map_grid(msg, geometry)
    if not np.isin(grid, (FIRE_BURNING, FIRE_NOT_BURNING)).all():
        raise _reject(DropReason.OUT_OF_RANGE, "fire grid values other than 0 and 100")
    return stamp, grid == FIRE_BURNING


def checked_belief_values(msg: Any, geometry: MapGeometry = PAPER_MAP) -> tuple[int, np.ndarray]:
    """Shared belief -> (stamp ns, (rows, cols) int8 grid of percent of burning)."""
    stamp = _stamp(msg.header)
    grid = _map_grid(msg, geometry)
    if grid.min() < FIRE_NOT_BURNING or grid.max() > FIRE_BURNING:
        raise _reject(DropReason.OUT_OF_RANGE, "belief values outside 0..100")
    return stamp, grid


def checked_belief_grid(msg: Any, geometry: MapGeometry = PAPER_MAP) -> tuple[int, np.ndarray]:
    """Shared belief (percent of burning) -> (stamp ns, float32 probability of burning)."""
    stamp, grid = checked_belief_values(msg, geometry)
    return stamp, belief_probability(grid)


def checked_fuel_grid(msg: Any, geometry: MapGeometry = PAPER_MAP) -> tuple[int, np.ndarray]:
    """Whole fuel map -> (stamp ns, (rows, cols) int16 fuel in 0..100)."""
    stamp = _stamp(msg.header)
    grid = _map_grid(msg, geometry)
    if grid.size and grid.min() < 0:
        raise _reject(DropReason.OUT_OF_RANGE, "fuel values below 0")
    return stamp, grid.astype(np.int16)


def checked_fuel_tile(msg: Any, geometry: MapGeometry = PAPER_MAP) -> Tile:
    """A fuel tile: on the tile grid of the map, of its tile's size, fuel in 0..100."""
    stamp = _stamp(msg.header)
    x, y = msg.info.origin.position.x, msg.info.origin.position.y
    cols, rows = (v / (CELL_SIZE_M * TILE) for v in (x, y))
    on_grid = all(math.isfinite(v) and v >= 0 and v == int(v) for v in (rows, cols))
    row0, col0 = (int(v) * TILE if on_grid else -1 for v in (rows, cols))
    if not on_grid or not geometry.inside(np.array(row0), np.array(col0)):
        raise _reject(DropReason.OUT_OF_RANGE, f"tile origin ({x:g}, {y:g}) off the tile grid")
    _grid_layout(msg, tile_shape(geometry, row0, col0), "tile")
    values = grid_from_msg(msg)
    if values.size and values.min() < 0:
        raise _reject(DropReason.OUT_OF_RANGE, "fuel values below 0")
    return Tile(stamp, row0, col0, values.astype(np.int16))


def checked_belief_delta(msg: Any, geometry: MapGeometry = PAPER_MAP) -> BeliefDelta:
    """Belief delta of a map of ``geometry``: increasing cells on the map, values in 0..100,
    ages in 0..255 s, a keyframe not after it and fewer ticks since it than keyframes lie
    apart."""
    delta = delta_from_msg(msg)
    if delta.stamp < 0 or not 0 <= delta.key_stamp <= delta.stamp:
        raise _reject(DropReason.OUT_OF_RANGE, f"stamps {delta.stamp}, {delta.key_stamp} ns")
    if not 1 <= delta.elapsed < KEYFRAME_TICKS:
        raise _reject(DropReason.OUT_OF_RANGE, f"{delta.elapsed} ticks since the keyframe")
    cells = delta.cells
    if cells.size and (cells[0] < 0 or cells[-1] >= geometry.cells or np.any(np.diff(cells) <= 0)):
        raise _reject(DropReason.OUT_OF_RANGE, "delta cells off the map or not increasing")
    if cells.size and (delta.values.min() < FIRE_NOT_BURNING or delta.values.max() > FIRE_BURNING):
        raise _reject(DropReason.OUT_OF_RANGE, "belief values outside 0..100")
    if cells.size and (delta.ticks.min() < 0 or delta.ticks.max() > AGE_CAP_TICKS):
        raise _reject(DropReason.OUT_OF_RANGE, f"ages outside 0..{AGE_CAP_TICKS} ticks")
    return delta


def checked_age_image(msg: Any, geometry: MapGeometry = PAPER_MAP) -> tuple[int, np.ndarray]:
    """Exact belief ages -> (stamp ns, (rows, cols) float32 seconds)."""
    stamp = _stamp(msg.header)
    _frame(msg.header)
    ages = age_image_from_msg(msg)
    if ages.shape != geometry.shape:
        raise _reject(DropReason.MALFORMED, f"age image {ages.shape}, expected a map-sized grid")
    if not _ages_ok(ages):
        raise _reject(DropReason.OUT_OF_RANGE, f"ages not finite or outside 0..{AGE_LIMIT_S:g} s")
    return stamp, ages


def checked_stamped_state(msg: Any, max_bank_rad: float) -> tuple[int, np.ndarray]:
    """Stamped exact state -> (stamp ns, ``[x_m, y_m, heading_rad, bank_rad]``)."""
    stamp = _stamp(msg.header)
    _frame(msg.header)
    if list(msg.name) != list(STATE_FIELDS):
        names = list(msg.name)
        raise _reject(DropReason.MALFORMED, f"joint names {names}, expected {STATE_FIELDS}")
    _, state = stamped_state_from_msg(msg)
    if not np.isfinite(state).all():
        raise _reject(DropReason.OUT_OF_RANGE, "state values not finite")
    x, y, heading, bank = state
    if max(abs(x), abs(y)) > POSITION_LIMIT_M or abs(heading) > HEADING_LIMIT_RAD:
        raise _reject(DropReason.OUT_OF_RANGE, f"position ({x:g}, {y:g}) or heading {heading:g}")
    if abs(bank) > max_bank_rad + 1e-9:
        raise _reject(DropReason.OUT_OF_RANGE, f"bank {bank:g} rad beyond +-{max_bank_rad:g}")
    return stamp, state


def checked_radio(msg: Any, sender: int, max_bank_steps: int) -> tuple[int, RadioMessage]:
    """Radio message of aircraft ``sender`` -> (stamp ns, message).

    The window's cells and bits are checked against the pose by the receiver, which knows
    which cells a pose visits (``wildfire_agent.aircraft_radio``).
    """
    message = radio_from_msg(msg)
    if message.aircraft != sender:
        raise _reject(
            DropReason.IMPERSONATION,
            f"aircraft {message.aircraft} on the radio topic of aircraft {sender}",
        )
    x, y, heading = message.x_m, message.y_m, message.heading_rad
    if not all(math.isfinite(v) for v in (x, y, heading)):
        raise _reject(DropReason.OUT_OF_RANGE, "pose values not finite")
    if max(abs(x), abs(y)) > POSITION_LIMIT_M or abs(heading) > HEADING_LIMIT_RAD:
        raise _reject(DropReason.OUT_OF_RANGE, f"position ({x:g}, {y:g}) or heading {heading:g}")
    if abs(message.bank_steps) > max_bank_steps:
        raise _reject(DropReason.OUT_OF_RANGE, f"bank {message.bank_steps} steps")
    return message.tick * DECISION_PERIOD_NS, message


def checked_visit(
    msg: Any, window_side: int, geometry: MapGeometry = PAPER_MAP
) -> tuple[int, VisitWindow]:
    """Visit or camera report window -> (stamp ns, window) of the expected size, origin on
    the cell grid, every reported cell on the map (an honest sensor sees no cell off it)."""
    stamp = _stamp(msg.header)
    _grid_layout(msg, (window_side, window_side), "window")
    x, y = msg.info.origin.position.x, msg.info.origin.position.y
    inside = all(
        math.isfinite(v) and -window_side <= v / CELL_SIZE_M <= side
        for v, side in ((x, geometry.cols), (y, geometry.rows))
    )
    if not inside:
        origin = (x, y)
        raise _reject(DropReason.OUT_OF_RANGE, f"window origin {origin} off the map")
    grid = grid_from_msg(msg)
    if not np.isin(grid, (UNKNOWN_CELL, FIRE_NOT_BURNING, FIRE_BURNING)).all():
        raise _reject(DropReason.OUT_OF_RANGE, "visit values other than -1, 0 and 100")
    window = visit_from_msg(msg)
    rows, cols = np.nonzero(window.visited)
    rows, cols = rows + window.row0, cols + window.col0
    if rows.size and not geometry.inside(rows, cols).all():
        raise _reject(DropReason.OUT_OF_RANGE, "reported cells off the map")
    return stamp, window


def checked_episode(msg: Any, seed: int) -> EpisodeStatus:
    """Status of the episode of ``seed`` (every node knows it), with a sane tick and flag."""
    if msg.name != EPISODE_NAME:
        raise _reject(DropReason.WRONG_FRAME, f"status name {msg.name!r}, expected {EPISODE_NAME}")
    status = episode_from_msg(msg)
    if status.values.get("seed") != str(seed):
        raise _reject(
            DropReason.WRONG_FRAME, f"episode seed {status.values.get('seed')!r}, expected {seed}"
        )
    try:
        tick = status.tick
    except ValueError:
        raise _reject(DropReason.MALFORMED, f"tick {status.values.get('tick')!r}") from None
    if tick < -1:
        raise _reject(DropReason.OUT_OF_RANGE, f"tick {tick}")
    if status.values.get("complete", "false") not in ("true", "false"):
        raise _reject(DropReason.MALFORMED, f"complete {status.values['complete']!r}")
    return status


def checked_ack(msg: Any, reporters: set[str]) -> tuple[str, int]:
    """Acknowledgement of a known reporter (``<name>`` or ``<name>/ready``) -> (name, stamp)."""
    reporter, stamp = ack_from_msg(msg)
    if reporter.removesuffix(READY_SUFFIX) not in reporters:
        raise _reject(DropReason.WRONG_FRAME, f"unknown reporter {reporter!r}")
    if stamp < 0:
        raise _reject(DropReason.OUT_OF_RANGE, f"negative stamp {stamp} ns")
    return reporter, stamp


def checked_snapshot(msg: Any, geometry: MapGeometry = PAPER_MAP) -> BeliefSnapshot:
    """Belief snapshot of a map-sized grid with finite, non-negative numbers."""
    snapshot = snapshot_from_msg(msg)
    if snapshot.believed.shape != geometry.shape:
        raise _reject(DropReason.MALFORMED, f"snapshot grid {snapshot.believed.shape}")
    numbers = (snapshot.time_s, snapshot.score)
    if not (all(math.isfinite(v) and v >= 0 for v in numbers) and _ages_ok(snapshot.age_s)):
        raise _reject(DropReason.OUT_OF_RANGE, "snapshot time, score or ages out of range")
    return snapshot


def checked_score(msg: Any) -> float:
    """Cumulative score: finite and non-negative."""
    score = float64_from_msg(msg)
    if not (math.isfinite(score) and score >= 0):
        raise _reject(DropReason.OUT_OF_RANGE, f"score {score}")
    return score


def _ages_ok(ages: np.ndarray) -> bool:
    return bool(np.isfinite(ages).all() and (ages >= 0).all() and (ages <= AGE_LIMIT_S).all())


__all__ = [
    "AGE_LIMIT_S",
    "HEADING_LIMIT_RAD",
    "POSITION_LIMIT_M",
    "checked_ack",
    "checked_age_image",
    "checked_belief_grid",
    "checked_episode",
    "checked_fire_grid",
    "checked_radio",
    "checked_score",
    "checked_snapshot",
    "checked_stamped_state",
    "checked_visit",
]
