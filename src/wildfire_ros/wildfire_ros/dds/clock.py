"""Time, Duration and Clock with rclpy's interface; the ROS clock follows ``/clock`` in sim time."""

from __future__ import annotations

import threading
import time
from enum import IntEnum
from functools import total_ordering
from typing import Any

from wildfire_msgs_py.types import get_message

_NS_PER_S = 1_000_000_000


class ClockType(IntEnum):
    """As ``rclpy.clock_type.ClockType``."""

    UNINITIALIZED = 0
    ROS_TIME = 1
    SYSTEM_TIME = 2
    STEADY_TIME = 3


@total_ordering
class Duration:
    """A signed span of time in integer nanoseconds (``rclpy.duration.Duration``)."""

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0) -> None:
        self.nanoseconds = round(seconds * _NS_PER_S) + int(nanoseconds)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Duration) and self.nanoseconds == other.nanoseconds

    def __lt__(self, other: Duration) -> bool:
        return self.nanoseconds < other.nanoseconds

    def __hash__(self) -> int:
        return hash(self.nanoseconds)

    def __repr__(self) -> str:
        return f"Duration(nanoseconds={self.nanoseconds})"

    def to_msg(self) -> Any:
        """As ``builtin_interfaces/msg/Duration``."""
        sec, nanosec = divmod(self.nanoseconds, _NS_PER_S)
        return get_message("builtin_interfaces/msg/Duration")(sec=sec, nanosec=nanosec)


@total_ordering
class Time:
    """A point in time of one clock, integer nanoseconds (``rclpy.time.Time``)."""

    def __init__(
        self,
        *,
        seconds: float = 0,
        nanoseconds: int = 0,
        clock_type: ClockType = ClockType.SYSTEM_TIME,
    ) -> None:
        self.nanoseconds = round(seconds * _NS_PER_S) + int(nanoseconds)
        if self.nanoseconds < 0:
            raise ValueError("time cannot be negative")
        self.clock_type = clock_type

    @classmethod
    def from_msg(cls, msg: Any, clock_type: ClockType = ClockType.ROS_TIME) -> Time:
        """From ``builtin_interfaces/msg/Time``."""
        return cls(nanoseconds=msg.sec * _NS_PER_S + msg.nanosec, clock_type=clock_type)

    def seconds_nanoseconds(self) -> tuple[int, int]:
        """(whole seconds, remaining nanoseconds)."""
        sec, nanosec = divmod(self.nanoseconds, _NS_PER_S)
        return sec, nanosec

    def to_msg(self) -> Any:
        """As ``builtin_interfaces/msg/Time``."""
        sec, nanosec = self.seconds_nanoseconds()
        return get_message("builtin_interfaces/msg/Time")(sec=sec, nanosec=nanosec)

    def __add__(self, other: Duration) -> Time:
        return Time(nanoseconds=self.nanoseconds + other.nanoseconds, clock_type=self.clock_type)

    def __sub__(self, other: Any) -> Any:
        if isinstance(other, Time):
            return Duration(nanoseconds=self.nanoseconds - other.nanoseconds)
        return Time(nanoseconds=self.nanoseconds - other.nanoseconds, clock_type=self.clock_type)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Time) and self.nanoseconds == other.nanoseconds

    def __lt__(self, other: Time) -> bool:
        return self.nanoseconds < other.nanoseconds

    def __hash__(self) -> int:
        return hash(self.nanoseconds)

    def __repr__(self) -> str:
        return f"Time(nanoseconds={self.nanoseconds}, clock_type={self.clock_type.name})"


class Clock:
    """A clock: the system clock, or a ROS clock that follows ``/clock`` when sim time is on."""

    def __init__(self, *, clock_type: ClockType = ClockType.SYSTEM_TIME) -> None:
        self.clock_type = clock_type
        self._lock = threading.Lock()
        self._ros_time_override: int | None = None

    @property
    def ros_time_is_active(self) -> bool:
        """True while the time comes from ``/clock`` (``use_sim_time``)."""
        return self._ros_time_override is not None

    def _set_ros_time_is_active(self, active: bool) -> None:
        with self._lock:
            if active and self._ros_time_override is None:
                self._ros_time_override = 0  # as rclpy: zero until the first /clock message
            elif not active:
                self._ros_time_override = None

    def _set_ros_time(self, nanoseconds: int) -> None:
        with self._lock:
            if self._ros_time_override is not None:
                self._ros_time_override = nanoseconds

    def now(self) -> Time:
        """The current time of this clock."""
        override = self._ros_time_override
        if override is not None:
            return Time(nanoseconds=override, clock_type=self.clock_type)
        if self.clock_type == ClockType.STEADY_TIME:
            return Time(nanoseconds=time.monotonic_ns(), clock_type=self.clock_type)
        return Time(nanoseconds=time.time_ns(), clock_type=self.clock_type)


class ROSClock(Clock):
    """The node clock (``rclpy.clock.ROSClock``)."""

    def __init__(self) -> None:
        super().__init__(clock_type=ClockType.ROS_TIME)


__all__ = ["Clock", "ClockType", "Duration", "ROSClock", "Time"]
