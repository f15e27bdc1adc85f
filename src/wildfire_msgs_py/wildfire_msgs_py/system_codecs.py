"""numpy/Python values <-> messages of the system topics (``contract.SYSTEM_TOPICS``).

Encodings:

* episode status -> ``diagnostic_msgs/DiagnosticStatus``: ``message`` is the phase
  (``waiting``, ``running``, ``terminated``, ``truncated``), ``name`` ``wildfire/episode``,
  key/value pairs hold the numbers and names as text (``tick``, ``time_s``, ``seed``, ...);
* lockstep acknowledgement -> ``std_msgs/Header``: ``frame_id`` = reporter, ``stamp`` = sim
  time of the tick the reporter has finished;
* exact belief age -> ``sensor_msgs/Image``, encoding ``32FC1``, row 0 south (the float32
  seconds ``SharedBelief.age_s()`` returns, so belief images rebuilt from it are bit-exact);
* stamped exact state -> ``sensor_msgs/JointState`` with names ``x_m, y_m, heading_rad,
  bank_rad`` and the float64 values as ``position``;
* belief snapshot -> ``std_msgs/Float64MultiArray`` ``[time_s, score, believed(H*W),
  age_s(H*W)]`` (every value exact in float64);
* ground (a ground file's bytes) -> ``std_msgs/UInt8MultiArray`` ``data``.
"""

from __future__ import annotations

import array
from typing import Any, NamedTuple

import numpy as np

from wildfire_msgs_py.codecs import (
    STATE_FIELDS,
    _message,
    _set_stamp,
    time_from_msg,
)
from wildfire_msgs_py.contract import MAP_FRAME
from wildfire_msgs_py.errors import MessageFieldError

EPISODE_NAME = "wildfire/episode"
PHASES = ("waiting", "running", "terminated", "truncated")
"""Phases of an episode; the last two are final."""
READY_SUFFIX = "/ready"
"""An acknowledgement ``<reporter>/ready`` says the reporter is up (lockstep start-up)."""


# --- episode status ------------------------------------------------------------------------------


class EpisodeStatus(NamedTuple):
    """What the fire simulator announces."""

    phase: str
    values: dict[str, str]

    @property
    def tick(self) -> int:
        """Decision index the status belongs to (-1 before the start)."""
        return int(self.values.get("tick", "-1"))

    @property
    def final(self) -> bool:
        """True once the episode has ended."""
        return self.phase in ("terminated", "truncated")


def episode_to_msg(phase: str, values: dict[str, Any], *, message_class: Any = None) -> Any:
    """Episode phase and values -> ``diagnostic_msgs/msg/DiagnosticStatus``."""
    from wildfire_msgs_py.messages import get_message

    if phase not in PHASES:
        raise ValueError(f"episode phase {phase!r}: expected one of {PHASES}")
    msg = _message("diagnostic_msgs/msg/DiagnosticStatus", message_class)
    key_value = get_message("diagnostic_msgs/msg/KeyValue")
    msg.level = type(msg).OK if hasattr(type(msg), "OK") else 0
    msg.name = EPISODE_NAME
    msg.message = phase
    msg.hardware_id = "fire_simulator"
    msg.values = [
        key_value(key=str(k), value=repr(float(v)) if isinstance(v, float) else str(v))
        for k, v in values.items()
    ]
    return msg


def episode_from_msg(msg: Any) -> EpisodeStatus:
    """``DiagnosticStatus`` -> :class:`EpisodeStatus`."""
    if msg.message not in PHASES:
        raise MessageFieldError(f"episode status {msg.message!r}: expected one of {PHASES}")
    return EpisodeStatus(str(msg.message), {str(p.key): str(p.value) for p in msg.values})


# --- acknowledgements ----------------------------------------------------------------------------


def ack_to_msg(reporter: str, stamp_ns: int, *, message_class: Any = None) -> Any:
    """Reporter name and finished tick time -> ``std_msgs/msg/Header``."""
    msg = _message("std_msgs/msg/Header", message_class)
    _set_stamp(msg, int(stamp_ns), reporter)
    return msg


def ack_from_msg(msg: Any) -> tuple[str, int]:
    """``Header`` -> (reporter, stamp in nanoseconds)."""
    return str(msg.frame_id), time_from_msg(msg.stamp)


# --- exact belief age ----------------------------------------------------------------------------


def age_image_to_msg(age_s: np.ndarray, stamp: Any = 0, *, message_class: Any = None) -> Any:
    """(H, W) float32 seconds -> ``sensor_msgs/msg/Image`` 32FC1 (row 0 south, little endian)."""
    ages = np.ascontiguousarray(age_s, dtype="<f4")
    if ages.ndim != 2:
        raise ValueError(f"expected a 2-D age grid, got shape {ages.shape}")
    msg = _message("sensor_msgs/msg/Image", message_class)
    _set_stamp(msg.header, stamp, MAP_FRAME)
    msg.height, msg.width = (int(n) for n in ages.shape)
    msg.encoding = "32FC1"
    msg.is_bigendian = 0
    msg.step = 4 * int(ages.shape[1])
    msg.data = array.array("B", ages.tobytes())
    return msg


def age_image_from_msg(msg: Any) -> np.ndarray:
    """``Image`` 32FC1 -> (H, W) float32 seconds."""
    if msg.encoding != "32FC1":
        raise MessageFieldError(f"belief age image: encoding {msg.encoding!r}, expected 32FC1")
    height, width = int(msg.height), int(msg.width)
    data = bytes(msg.data) if isinstance(msg.data, list) else msg.data
    values = np.frombuffer(data, dtype=">f4" if msg.is_bigendian else "<f4")
    if values.size != height * width:
        raise MessageFieldError(
            f"belief age image: {values.size} values, expected {height * width}"
        )
    return values.reshape(height, width).astype(np.float32)


# --- stamped exact state -------------------------------------------------------------------------


def stamped_state_to_msg(state: Any, stamp: Any = 0, *, message_class: Any = None) -> Any:
    """Exact ``[x_m, y_m, heading_rad, bank_rad]`` and its time -> ``sensor_msgs/JointState``."""
    values = np.asarray(state, dtype=np.float64).reshape(-1)
    if values.size != len(STATE_FIELDS):
        raise ValueError(f"expected {len(STATE_FIELDS)} state values, got {values.size}")
    msg = _message("sensor_msgs/msg/JointState", message_class)
    _set_stamp(msg.header, stamp, MAP_FRAME)
    msg.name = list(STATE_FIELDS)
    msg.position = array.array("d", values.tobytes())
    return msg


def stamped_state_from_msg(msg: Any) -> tuple[int, np.ndarray]:
    """``JointState`` -> (stamp in nanoseconds, float64 state of 4 values)."""
    values = np.asarray(msg.position, dtype=np.float64)
    if values.size != len(STATE_FIELDS):
        raise MessageFieldError(
            f"stamped state: {values.size} values, expected {len(STATE_FIELDS)} {STATE_FIELDS}"
        )
    return time_from_msg(msg.header.stamp), values.copy()


# --- belief snapshot -----------------------------------------------------------------------------


class BeliefSnapshot(NamedTuple):
    """A copy of the shared belief at one time."""

    time_s: float
    score: float
    believed: np.ndarray
    """(H, W) bool."""
    age_s: np.ndarray
    """(H, W) float32 seconds."""


def snapshot_to_msg(snapshot: BeliefSnapshot, *, message_class: Any = None) -> Any:
    """Belief snapshot -> ``std_msgs/Float64MultiArray``."""
    believed = np.asarray(snapshot.believed, dtype=np.float64).reshape(-1)
    ages = np.asarray(snapshot.age_s, dtype=np.float64).reshape(-1)
    values = np.concatenate([[snapshot.time_s, snapshot.score], believed, ages])
    msg = _message("std_msgs/msg/Float64MultiArray", message_class)
    dim = _message("std_msgs/msg/MultiArrayDimension")
    rows, cols = np.asarray(snapshot.believed).shape
    dim.label = f"time_s,score,believed[{rows}x{cols}],age_s[{rows}x{cols}]"
    dim.size, dim.stride = values.size, values.size
    # The grids' shape (a field map need not be square): two more dimensions, rows and cols.
    dims = [dim]
    for label, size, stride in (("rows", rows, rows * cols), ("cols", cols, cols)):
        grid_dim = _message("std_msgs/msg/MultiArrayDimension")
        grid_dim.label, grid_dim.size, grid_dim.stride = label, int(size), int(stride)
        dims.append(grid_dim)
    msg.layout.dim = dims
    msg.data = array.array("d", values.tobytes())
    return msg


def snapshot_from_msg(msg: Any) -> BeliefSnapshot:
    """``Float64MultiArray`` -> :class:`BeliefSnapshot`: grids of the layout's ``rows`` and
    ``cols`` dimensions (square ones when the layout has none)."""
    values = np.asarray(msg.data, dtype=np.float64)
    cells = (values.size - 2) // 2
    sizes = {d.label: int(d.size) for d in msg.layout.dim[1:]}
    if "rows" in sizes and "cols" in sizes:
        grid = (sizes["rows"], sizes["cols"])
    else:
        side = round(float(np.sqrt(max(cells, 0))))
        grid = (side, side)
    if values.size < 4 or grid[0] * grid[1] != cells or 2 + 2 * cells != values.size:
        raise MessageFieldError(
            f"belief snapshot: {values.size} values do not hold 2 grids of {grid[0]}x{grid[1]}"
        )
    return BeliefSnapshot(
        time_s=float(values[0]),
        score=float(values[1]),
        believed=values[2 : 2 + cells].reshape(grid) > 0.5,
        age_s=values[2 + cells :].reshape(grid).astype(np.float32),
    )


def ground_to_msg(data: bytes, *, message_class: Any = None) -> Any:
    """A ground file's bytes -> ``std_msgs/UInt8MultiArray``."""
    msg = _message("std_msgs/msg/UInt8MultiArray", message_class)
    msg.data = array.array("B", data)
    return msg


def ground_from_msg(msg: Any) -> bytes:
    return bytes(msg.data)


__all__ = [
    "EPISODE_NAME",
    "PHASES",
    "READY_SUFFIX",
    "BeliefSnapshot",
    "EpisodeStatus",
    "ack_from_msg",
    "ack_to_msg",
    "age_image_from_msg",
    "age_image_to_msg",
    "episode_from_msg",
    "episode_to_msg",
    "ground_from_msg",
    "ground_to_msg",
    "snapshot_from_msg",
    "snapshot_to_msg",
    "stamped_state_from_msg",
    "stamped_state_to_msg",
]
