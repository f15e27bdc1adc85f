"""numpy arrays <-> ROS 2 messages for every topic of the contract.

Encoders build messages of the active runtime backend (real rosidl classes under rclpy, the
generated classes of the DDS backend) unless ``message_class`` is given; decoders only read
attributes, so they also accept messages read back from a bag by rosbags (numpy fields).
All grid conversions are bulk (``tobytes``/``frombuffer``/``array.array``), never per cell.

Encodings (grids are ``[row, col]``, row 0 at the south, cells of ``resolution`` metres, origin
at the grid's south-west corner in frame ``map``, exactly the ``OccupancyGrid`` layout):

* fire / belief grid: 100 burning, 0 not burning (``FIRE_BURNING``/``FIRE_NOT_BURNING``);
* fuel grid: the integer fuel value itself (0..20, at most 100 fits), no scaling;
* belief age: seconds since visited, 0..255 s, stored as ``round(age / 255 * 100)``; decoding
  returns ``value * 2.55`` s, so it is exact to +-1.28 s (display and logging, not training);
* visit window: an ``n x n`` window of cells whose ``info.origin`` is the window's south-west
  corner (cell ``row0, col0``); visited cells carry 100/0 truth, all others -1;
* aircraft pose -> ``nav_msgs/Odometry``: frame ``map``, child ``uavK/base_link``,
  orientation from roll = bank, pitch = 0, yaw = heading (x east, y north, yaw from east
  counter-clockwise), twist in the body frame: ``linear.x`` = airspeed (20 m/s),
  ``angular.z`` = yaw rate ``g tan(bank) / v``;
* exact aircraft state -> ``std_msgs/Float64MultiArray`` ``[x_m, y_m, heading_rad, bank_rad]``
  (float64, bit-exact, unlike the quaternion of the odometry);
* score and bank command -> ``std_msgs/Float64``;
* node statuses (:class:`NodeStatus`) -> ``diagnostic_msgs/DiagnosticArray`` on ``/diagnostics``,
  key/value pairs holding the numbers as text; an agent's status is named
  ``uavK/agent: decision deadlines`` with hardware id ``uavK``.
"""

from __future__ import annotations

import array
import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from wildfire_msgs_py.contract import CELL_SIZE_M, MAP_FRAME, base_link_frame
from wildfire_msgs_py.errors import MessageFieldError

FIRE_BURNING = 100
FIRE_NOT_BURNING = 0
BELIEVED_ABOVE = FIRE_BURNING // 2
"""A shared-belief cell is believed burning when its value is above this (percent)."""
UNKNOWN_CELL = -1
AGE_MAX_S = 255.0
"""Cap of the belief age in seconds."""
AIRSPEED_MPS = 20.0
GRAVITY_MPS2 = 9.81
STATE_FIELDS = ("x_m", "y_m", "heading_rad", "bank_rad")
_NS_PER_S = 1_000_000_000


def _message(type_name: str, message_class: Any = None) -> Any:
    if message_class is not None:
        return message_class()
    from wildfire_msgs_py.messages import get_message

    return get_message(type_name)()


# --- time ----------------------------------------------------------------------------------------


def time_to_msg(nanoseconds: int, message_class: Any = None) -> Any:
    """Integer nanoseconds -> ``builtin_interfaces/msg/Time``."""
    msg = _message("builtin_interfaces/msg/Time", message_class)
    msg.sec, msg.nanosec = divmod(int(nanoseconds), _NS_PER_S)
    return msg


def time_from_msg(msg: Any) -> int:
    """``builtin_interfaces/msg/Time`` -> integer nanoseconds."""
    return int(msg.sec) * _NS_PER_S + int(msg.nanosec)


def seconds_from_msg(msg: Any) -> float:
    """``builtin_interfaces/msg/Time`` -> float seconds."""
    return time_from_msg(msg) / _NS_PER_S


def clock_to_msg(nanoseconds: int, message_class: Any = None) -> Any:
    """Sim time in nanoseconds -> ``rosgraph_msgs/msg/Clock``."""
    msg = _message("rosgraph_msgs/msg/Clock", message_class)
    msg.clock.sec, msg.clock.nanosec = divmod(int(nanoseconds), _NS_PER_S)
    return msg


def clock_from_msg(msg: Any) -> int:
    """``rosgraph_msgs/msg/Clock`` -> nanoseconds."""
    return time_from_msg(msg.clock)


def _set_stamp(header: Any, stamp: Any, frame_id: str) -> None:
    """Fill a header from a Time message or integer nanoseconds."""
    header.frame_id = frame_id
    if isinstance(stamp, int | np.integer):
        header.stamp.sec, header.stamp.nanosec = divmod(int(stamp), _NS_PER_S)
    elif stamp is not None:
        header.stamp.sec, header.stamp.nanosec = int(stamp.sec), int(stamp.nanosec)


# --- occupancy grids -----------------------------------------------------------------------------


def grid_to_msg(
    values: np.ndarray,
    stamp: Any = 0,
    *,
    resolution: float = CELL_SIZE_M,
    origin_xy: tuple[float, float] = (0.0, 0.0),
    frame_id: str = MAP_FRAME,
    message_class: Any = None,
) -> Any:
    """An int8 ``[row, col]`` array (row 0 south) -> ``nav_msgs/msg/OccupancyGrid``."""
    grid = np.asarray(values)
    if grid.ndim != 2:
        raise ValueError(f"expected a 2-D grid, got shape {grid.shape}")
    if grid.size and (grid.min() < -128 or grid.max() > 127):
        raise ValueError("grid values must fit int8 (-128..127)")
    msg = _message("nav_msgs/msg/OccupancyGrid", message_class)
    _set_stamp(msg.header, stamp, frame_id)
    msg.info.resolution = float(resolution)
    msg.info.height, msg.info.width = (int(n) for n in grid.shape)
    msg.info.origin.position.x = float(origin_xy[0])
    msg.info.origin.position.y = float(origin_xy[1])
    msg.info.origin.orientation.w = 1.0
    msg.data = array.array("b", np.ascontiguousarray(grid, dtype=np.int8).tobytes())
    return msg


def grid_from_msg(msg: Any) -> np.ndarray:
    """``nav_msgs/msg/OccupancyGrid`` -> int8 array of shape (height, width), row 0 south."""
    height, width = int(msg.info.height), int(msg.info.width)
    data = msg.data
    values = (
        np.asarray(data, dtype=np.int8)
        if isinstance(data, list)
        else np.frombuffer(data, dtype=np.int8)
    )
    if values.size != height * width:
        raise MessageFieldError(
            f"OccupancyGrid: {values.size} data values, expected width*height = {width * height}"
        )
    return values.reshape(height, width).copy()


def fire_grid_to_msg(burning: np.ndarray, stamp: Any = 0, *, message_class: Any = None) -> Any:
    """Burning mask (bool or 0/1) -> grid with 100 burning / 0 not burning."""
    grid = np.where(np.asarray(burning, dtype=bool), FIRE_BURNING, FIRE_NOT_BURNING)
    return grid_to_msg(grid, stamp, message_class=message_class)


def fire_grid_from_msg(msg: Any) -> np.ndarray:
    """Grid with 100 burning -> bool mask (any value >= 50 counts as burning)."""
    return grid_from_msg(msg) >= FIRE_BURNING // 2


def fuel_grid_to_msg(fuel: np.ndarray, stamp: Any = 0, *, message_class: Any = None) -> Any:
    """Integer fuel (0..100, 0..20 in the model) stored directly in each cell."""
    values = np.asarray(fuel)
    if values.size and (values.min() < 0 or values.max() > 100):
        raise ValueError("fuel values must lie in 0..100 to fit an OccupancyGrid")
    return grid_to_msg(np.rint(values).astype(np.int8), stamp, message_class=message_class)


def fuel_grid_from_msg(msg: Any) -> np.ndarray:
    """Fuel grid -> int16 fuel values."""
    return grid_from_msg(msg).astype(np.int16)


def belief_age_display(age_s: np.ndarray) -> np.ndarray:
    """Seconds since visited (0..255, clipped) -> int8 0..100 (rounded): the display age."""
    ages = np.clip(np.asarray(age_s, dtype=np.float64), 0.0, AGE_MAX_S)
    return np.rint(ages * (100.0 / AGE_MAX_S)).astype(np.int8)


def belief_age_to_msg(age_s: np.ndarray, stamp: Any = 0, *, message_class: Any = None) -> Any:
    """Seconds since visited -> grid of display ages (:func:`belief_age_display`)."""
    return grid_to_msg(belief_age_display(age_s), stamp, message_class=message_class)


def belief_age_from_msg(msg: Any) -> np.ndarray:
    """Scaled age grid -> seconds (float64, quantized to 2.55 s)."""
    return grid_from_msg(msg).astype(np.float64) * (AGE_MAX_S / 100.0)


@dataclass(frozen=True)
class VisitWindow:
    """Cells an aircraft visited in one decision, as a small window of the grid."""

    row0: int
    """Grid row of the window's southern row (may lie outside the grid near a border)."""
    col0: int
    """Grid column of the window's western column."""
    visited: np.ndarray
    """Bool mask (n, n): cells whose centre lies within the visit radius and inside the map."""
    burning: np.ndarray
    """Bool (n, n): true burning state of the visited cells (False elsewhere)."""

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, VisitWindow)
            and (self.row0, self.col0) == (other.row0, other.col0)
            and np.array_equal(self.visited, other.visited)
            and np.array_equal(self.burning & self.visited, other.burning & other.visited)
        )

    __hash__ = None  # type: ignore[assignment]


def visit_to_msg(
    window: VisitWindow,
    stamp: Any = 0,
    *,
    resolution: float = CELL_SIZE_M,
    message_class: Any = None,
) -> Any:
    """Visit window -> grid: 100/0 truth in visited cells, -1 elsewhere; origin = SW corner."""
    visited = np.asarray(window.visited, dtype=bool)
    burning = np.asarray(window.burning, dtype=bool)
    if visited.shape != burning.shape:
        raise ValueError(f"visited {visited.shape} and burning {burning.shape} shapes differ")
    grid = np.where(visited, np.where(burning, FIRE_BURNING, FIRE_NOT_BURNING), UNKNOWN_CELL)
    origin = (window.col0 * resolution, window.row0 * resolution)
    return grid_to_msg(
        grid, stamp, resolution=resolution, origin_xy=origin, message_class=message_class
    )


def visit_from_msg(msg: Any) -> VisitWindow:
    """Grid -> visit window (row/col origin from ``info.origin`` and the resolution)."""
    grid = grid_from_msg(msg)
    resolution = float(msg.info.resolution)
    if resolution <= 0:
        raise MessageFieldError(f"visit grid: resolution {resolution}, expected > 0")
    col0 = round(msg.info.origin.position.x / resolution)
    row0 = round(msg.info.origin.position.y / resolution)
    visited = grid >= 0
    return VisitWindow(row0, col0, visited, visited & (grid >= FIRE_BURNING // 2))


# --- aircraft ------------------------------------------------------------------------------------


class AircraftPose(NamedTuple):
    """Planar aircraft state."""

    x_m: float
    y_m: float
    heading_rad: float
    bank_rad: float


def yaw_rate(
    bank_rad: float, airspeed: float = AIRSPEED_MPS, gravity: float = GRAVITY_MPS2
) -> float:
    """Coordinated-turn yaw rate ``g tan(bank) / v`` in rad/s."""
    return gravity * math.tan(bank_rad) / airspeed


def pose_to_odometry(
    pose: AircraftPose | np.ndarray | tuple[float, float, float, float],
    aircraft: int,
    stamp: Any = 0,
    *,
    altitude_m: float = 0.0,
    airspeed: float = AIRSPEED_MPS,
    message_class: Any = None,
) -> Any:
    """Aircraft pose -> ``nav_msgs/msg/Odometry`` (roll = bank, yaw = heading)."""
    x, y, heading, bank = (float(v) for v in pose)
    msg = _message("nav_msgs/msg/Odometry", message_class)
    _set_stamp(msg.header, stamp, MAP_FRAME)
    msg.child_frame_id = base_link_frame(aircraft)
    position = msg.pose.pose.position
    position.x, position.y, position.z = x, y, float(altitude_m)
    half_roll, half_yaw = bank / 2.0, heading / 2.0
    q = msg.pose.pose.orientation
    q.w = math.cos(half_roll) * math.cos(half_yaw)
    q.x = math.sin(half_roll) * math.cos(half_yaw)
    q.y = math.sin(half_roll) * math.sin(half_yaw)
    q.z = math.cos(half_roll) * math.sin(half_yaw)
    msg.twist.twist.linear.x = float(airspeed)
    msg.twist.twist.angular.z = yaw_rate(bank, airspeed)
    return msg


def odometry_to_pose(msg: Any) -> AircraftPose:
    """``nav_msgs/msg/Odometry`` -> pose (heading and bank from the quaternion; ~1e-16 rad)."""
    q = msg.pose.pose.orientation
    roll = math.atan2(2.0 * (q.w * q.x + q.y * q.z), 1.0 - 2.0 * (q.x * q.x + q.y * q.y))
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    position = msg.pose.pose.position
    return AircraftPose(float(position.x), float(position.y), yaw, roll)


def state_to_msg(
    state: AircraftPose | np.ndarray | tuple[float, ...], *, message_class: Any = None
) -> Any:
    """Exact state ``[x_m, y_m, heading_rad, bank_rad]`` -> ``std_msgs/msg/Float64MultiArray``."""
    values = np.asarray(state, dtype=np.float64).reshape(-1)
    if values.size != len(STATE_FIELDS):
        raise ValueError(f"expected {len(STATE_FIELDS)} state values, got {values.size}")
    msg = _message("std_msgs/msg/Float64MultiArray", message_class)
    dim = _message("std_msgs/msg/MultiArrayDimension")
    dim.label, dim.size, dim.stride = "x_m,y_m,heading_rad,bank_rad", values.size, values.size
    msg.layout.dim = [dim]
    msg.data = array.array("d", values.tobytes())
    return msg


def state_from_msg(msg: Any) -> np.ndarray:
    """``Float64MultiArray`` -> float64 array of the 4 state values (bit-exact)."""
    data = msg.data
    values = (
        np.asarray(data, dtype=np.float64)
        if isinstance(data, list)
        else np.frombuffer(data, dtype=np.float64)
    )
    if values.size != len(STATE_FIELDS):
        raise MessageFieldError(
            f"state message: {values.size} values, expected {len(STATE_FIELDS)} {STATE_FIELDS}"
        )
    return values.copy()


def float64_to_msg(value: float, *, message_class: Any = None) -> Any:
    """A number -> ``std_msgs/msg/Float64`` (score, bank command)."""
    msg = _message("std_msgs/msg/Float64", message_class)
    msg.data = float(value)
    return msg


def float64_from_msg(msg: Any) -> float:
    """``std_msgs/msg/Float64`` -> float."""
    return float(msg.data)


score_to_msg = float64_to_msg
score_from_msg = float64_from_msg
bank_cmd_to_msg = float64_to_msg
bank_cmd_from_msg = float64_from_msg


def action_to_msg(action: int, *, message_class: Any = None) -> Any:
    """A decision's integer action -> ``std_msgs/msg/Int8``."""
    msg = _message("std_msgs/msg/Int8", message_class)
    msg.data = int(action)
    return msg


def action_from_msg(msg: Any) -> int:
    """``std_msgs/msg/Int8`` -> the integer action (its range is the reader's to check)."""
    return int(msg.data)


class NodeStatus(NamedTuple):
    """One status of ``/diagnostics`` (``diagnostic_msgs/msg/DiagnosticStatus``)."""

    name: str
    """``<node>: <what>``, as diagnostic_updater names its tasks."""
    hardware_id: str
    level: str
    """``OK``, ``WARN``, ``ERROR`` or ``STALE``."""
    message: str
    values: dict[str, float | int | str]


def diagnostics_to_msg(statuses: list[NodeStatus], stamp: Any = 0) -> Any:
    """Statuses -> ``diagnostic_msgs/msg/DiagnosticArray``; numbers written with ``repr``."""
    from wildfire_msgs_py.messages import get_message

    msg = _message("diagnostic_msgs/msg/DiagnosticArray")
    _set_stamp(msg.header, stamp, "")
    status_class = get_message("diagnostic_msgs/msg/DiagnosticStatus")
    key_value = get_message("diagnostic_msgs/msg/KeyValue")
    entries = []
    for status in statuses:
        entry = status_class()
        entry.level = getattr(status_class, status.level)
        entry.name = status.name
        entry.message = status.message
        entry.hardware_id = status.hardware_id
        entry.values = [
            key_value(key=str(k), value=repr(float(v)) if isinstance(v, float) else str(v))
            for k, v in status.values.items()
        ]
        entries.append(entry)
    msg.status = entries
    return msg


_LEVELS = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}


def diagnostics_from_msg(msg: Any) -> list[NodeStatus]:
    """DiagnosticArray -> statuses; values that parse as numbers become floats."""
    statuses = []
    for entry in msg.status:
        level = entry.level
        level = int.from_bytes(level, "little") if isinstance(level, bytes) else int(level)
        values: dict[str, float | int | str] = {}
        for pair in entry.values:
            try:
                values[pair.key] = float(pair.value)
            except ValueError:
                values[pair.key] = pair.value
        statuses.append(
            NodeStatus(
                entry.name, entry.hardware_id, _LEVELS.get(level, "ERROR"), entry.message, values
            )
        )
    return statuses


__all__ = [
    "AGE_MAX_S",
    "AIRSPEED_MPS",
    "BELIEVED_ABOVE",
    "FIRE_BURNING",
    "FIRE_NOT_BURNING",
    "GRAVITY_MPS2",
    "STATE_FIELDS",
    "UNKNOWN_CELL",
    "AircraftPose",
    "NodeStatus",
    "VisitWindow",
    "action_from_msg",
    "action_to_msg",
    "bank_cmd_from_msg",
    "bank_cmd_to_msg",
    "belief_age_display",
    "belief_age_from_msg",
    "belief_age_to_msg",
    "clock_from_msg",
    "clock_to_msg",
    "diagnostics_from_msg",
    "diagnostics_to_msg",
    "fire_grid_from_msg",
    "fire_grid_to_msg",
    "float64_from_msg",
    "float64_to_msg",
    "fuel_grid_from_msg",
    "fuel_grid_to_msg",
    "grid_from_msg",
    "grid_to_msg",
    "odometry_to_pose",
    "pose_to_odometry",
    "score_from_msg",
    "score_to_msg",
    "seconds_from_msg",
    "state_from_msg",
    "state_to_msg",
    "time_from_msg",
    "time_to_msg",
    "visit_from_msg",
    "visit_to_msg",
    "yaw_rate",
]
