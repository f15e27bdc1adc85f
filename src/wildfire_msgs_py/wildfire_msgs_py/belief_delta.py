"""The shared belief on the wire at any map size: whole keyframes, then per-tick deltas.

A whole belief is a map-sized grid: 10 kB on the paper's map, 1 MB at 1000 x 1000, and with
its exact ages (float32) five times that, every tick. So the belief aggregator sends the whole
grids (``/wildfire/belief``, ``/wildfire/belief_age``, ``/wildfire/belief_age_exact``) once
every :data:`KEYFRAME_TICKS` ticks (each fire step, 0.4 Hz) and, on every tick between, a
:class:`BeliefDelta` on ``/wildfire/belief_delta``: the cells whose value or age differs from
what the keyframe predicts (its ages plus the ticks since). A visit changes only the cells
it reports, so a delta grows with the aircraft and the burning front, not with the map.

:class:`DeltaEncoder` (the aggregator) makes keyframes and deltas; :class:`BeliefMirror`
(every reader: agents, the run monitor, the live view, tools) rebuilds the grid and its
exact ages of every tick, bit for bit, from a keyframe and a delta of that keyframe, in any
order of arrival. A delta holds everything since its keyframe, so a lost delta loses only
its own tick.

Wire form of a delta, ``std_msgs/Int32MultiArray``: ``[stamp_s, stamp_ns, key_stamp_s,
key_stamp_ns, elapsed_ticks, n, cells(n), values(n), age_ticks(n)]``, cells flat row-major
indices (row 0 south), values the belief grid's (percent), ages in ticks of 0.1 s (capped
at 255 s). Its layout's dimensions name the parts.
"""

from __future__ import annotations

import array
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from wildfire_msgs_py.codecs import AGE_MAX_S, _message
from wildfire_msgs_py.contract import DECISION_PERIOD_NS
from wildfire_msgs_py.errors import MessageFieldError

KEYFRAME_TICKS = 25
"""Ticks from one whole keyframe to the next (a fire step: 2.5 s)."""
TICKS_PER_S = 1_000_000_000 // DECISION_PERIOD_NS
AGE_CAP_TICKS = round(AGE_MAX_S * TICKS_PER_S)
"""Ages stop at 255 s: 2550 ticks (as the belief's ``AGE_CAP_TICKS``)."""
HEADER_WORDS = 6
"""Words before the cells: the two stamps (seconds, nanoseconds), elapsed ticks, count."""
KEYFRAMES_KEPT = 4
"""Keyframes a mirror keeps (a delta may arrive before its keyframe, or after the next)."""
PENDING_KEPT = 4 * KEYFRAME_TICKS
"""Deltas a mirror holds for a keyframe it has not received yet."""


def age_ticks(age_s: np.ndarray) -> np.ndarray:
    """Exact ages (float32 seconds, ``ticks / 10`` in float32) -> int32 ticks."""
    return np.rint(np.asarray(age_s, dtype=np.float64) * TICKS_PER_S).astype(np.int32)


def ages_of(ticks: np.ndarray) -> np.ndarray:
    """int ticks -> float32 seconds, as the belief computes them (``age_seconds``)."""
    ages = np.asarray(ticks, dtype=np.float32)
    return ages / np.float32(TICKS_PER_S)


class Frame(NamedTuple):
    """The whole belief of one tick: its grid (int8, percent) and exact ages (float32 s)."""

    stamp: int
    grid: np.ndarray
    age_s: np.ndarray


@dataclass(frozen=True)
class BeliefDelta:
    """The cells of tick ``stamp`` that differ from keyframe ``key_stamp``'s prediction."""

    stamp: int
    key_stamp: int
    elapsed: int
    """Belief ticks since the keyframe (every unchanged cell aged by this many)."""
    cells: np.ndarray
    """(n,) int64 flat cell indices, row-major, row 0 south."""
    values: np.ndarray
    """(n,) grid values (percent)."""
    ticks: np.ndarray
    """(n,) int32 ages in ticks."""


class DeltaEncoder:
    """The aggregator's side: a keyframe every :data:`KEYFRAME_TICKS`, deltas between."""

    def __init__(self, every: int = KEYFRAME_TICKS) -> None:
        self.every = every
        self.key: Frame | None = None
        self.key_ticks = np.zeros(0, dtype=np.int32)
        self.key_clock = 0

    def encode(
        self, stamp: int, grid: np.ndarray, age_s: np.ndarray, clock: int
    ) -> Frame | BeliefDelta:
        """The message of tick ``stamp``: ``grid`` and ``age_s`` are the whole belief, ``clock``
        the belief's tick counter (its ages grow by one per tick of it)."""
        if self.key is None or clock - self.key_clock >= self.every or clock < self.key_clock:
            self.key = Frame(stamp, np.array(grid, dtype=np.int8), np.array(age_s, np.float32))
            self.key_ticks = age_ticks(age_s).reshape(-1)
            self.key_clock = clock
            return self.key
        elapsed = clock - self.key_clock
        ticks = age_ticks(age_s).reshape(-1)
        predicted = np.minimum(self.key_ticks + elapsed, AGE_CAP_TICKS)
        values = np.asarray(grid, dtype=np.int8).reshape(-1)
        cells = np.flatnonzero((values != self.key.grid.reshape(-1)) | (ticks != predicted))
        return BeliefDelta(
            stamp, self.key.stamp, elapsed, cells, values[cells].astype(np.int64), ticks[cells]
        )


class BeliefMirror:
    """A reader's side: whole frames rebuilt from keyframes and their deltas (see the module
    docstring). A keyframe needs its grid and its exact ages, which come on two topics."""

    def __init__(self) -> None:
        self.keys: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        """Complete keyframes by stamp: grid and ages in ticks (flat)."""
        self.halves: dict[int, dict[str, np.ndarray]] = {}
        self.pending: dict[int, list[BeliefDelta]] = {}
        self.shape: tuple[int, int] | None = None

    def on_key_grid(self, stamp: int, grid: np.ndarray) -> list[Frame]:
        return self._half(stamp, "grid", np.asarray(grid, dtype=np.int8))

    def on_key_ages(self, stamp: int, age_s: np.ndarray) -> list[Frame]:
        return self._half(stamp, "ages", np.asarray(age_s, dtype=np.float32))

    def on_delta(self, delta: BeliefDelta) -> list[Frame]:
        if delta.key_stamp in self.keys:
            return [self._rebuild(delta)]
        waiting = self.pending.setdefault(delta.key_stamp, [])
        waiting.append(delta)
        while sum(len(v) for v in self.pending.values()) > PENDING_KEPT:
            self.pending.pop(min(self.pending))
        return []

    def _half(self, stamp: int, part: str, values: np.ndarray) -> list[Frame]:
        half = self.halves.setdefault(stamp, {})
        half[part] = values
        if len(half) < 2:
            while len(self.halves) > KEYFRAMES_KEPT:
                self.halves.pop(min(self.halves))
            return []
        del self.halves[stamp]
        grid, ages = half["grid"], half["ages"]
        if grid.shape != ages.shape:
            raise MessageFieldError(f"belief keyframe: grid {grid.shape}, ages {ages.shape}")
        self.shape = (int(grid.shape[0]), int(grid.shape[1]))
        self.keys[stamp] = (grid.reshape(-1), age_ticks(ages).reshape(-1))
        while len(self.keys) > KEYFRAMES_KEPT:
            self.keys.pop(min(self.keys))
        frames = [Frame(stamp, grid, ages)]
        return frames + [self._rebuild(d) for d in self.pending.pop(stamp, [])]

    def _rebuild(self, delta: BeliefDelta) -> Frame:
        key_grid, key_ticks = self.keys[delta.key_stamp]
        assert self.shape is not None
        if delta.cells.size and int(delta.cells.max()) >= key_grid.size:
            raise MessageFieldError(f"belief delta: cell {int(delta.cells.max())} off the map")
        grid = key_grid.copy()
        grid[delta.cells] = delta.values
        ticks = np.minimum(key_ticks + delta.elapsed, AGE_CAP_TICKS)
        ticks[delta.cells] = delta.ticks
        return Frame(delta.stamp, grid.reshape(self.shape), ages_of(ticks).reshape(self.shape))


# --- wire -------------------------------------------------------------------------------------


def _split(stamp: int) -> tuple[int, int]:
    return stamp // 1_000_000_000, stamp % 1_000_000_000


def delta_to_msg(delta: BeliefDelta, *, message_class: Any = None) -> Any:
    """:class:`BeliefDelta` -> ``std_msgs/Int32MultiArray`` (module docstring)."""
    n = int(delta.cells.size)
    header = [*_split(delta.stamp), *_split(delta.key_stamp), delta.elapsed, n]
    values = np.concatenate(
        [np.asarray(header), delta.cells, delta.values.astype(np.int64), delta.ticks]
    ).astype("<i4")
    msg = _message("std_msgs/msg/Int32MultiArray", message_class)
    dims = []
    parts = [("stamp_s,stamp_ns,key_s,key_ns,elapsed,n", HEADER_WORDS)]
    for label, size in parts + [(part, n) for part in ("cells", "values", "age_ticks")]:
        dim = _message("std_msgs/msg/MultiArrayDimension")
        dim.label, dim.size, dim.stride = label, size, size
        dims.append(dim)
    msg.layout.dim = dims
    msg.data = array.array("i", values.tobytes())
    return msg


def delta_from_msg(msg: Any) -> BeliefDelta:
    """``Int32MultiArray`` -> :class:`BeliefDelta` (sizes checked, values not)."""
    words = np.asarray(msg.data, dtype=np.int64)
    if words.size < HEADER_WORDS:
        raise MessageFieldError(f"belief delta: {words.size} words, expected at least 6")
    stamp_s, stamp_ns, key_s, key_ns, elapsed, n = (int(v) for v in words[:HEADER_WORDS])
    if n < 0 or words.size != HEADER_WORDS + 3 * n:
        raise MessageFieldError(f"belief delta: {words.size} words do not hold {n} cells")
    body = words[HEADER_WORDS:].reshape(3, n)
    return BeliefDelta(
        stamp_s * 1_000_000_000 + stamp_ns,
        key_s * 1_000_000_000 + key_ns,
        elapsed,
        body[0].copy(),
        body[1].copy(),
        body[2].copy(),
    )


__all__ = [
    "AGE_CAP_TICKS",
    "KEYFRAME_TICKS",
    "BeliefDelta",
    "BeliefMirror",
    "DeltaEncoder",
    "Frame",
    "age_ticks",
    "ages_of",
    "delta_from_msg",
    "delta_to_msg",
]
