"""Publisher, Subscription and Timer of the DDS backend (rclpy's interfaces)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from cyclonedds._clayer import ddspy_take
from cyclonedds.core import DDSException, InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.util import duration

from wildfire_ros.dds.qos import QoSProfile, ReliabilityPolicy, to_cyclone

if TYPE_CHECKING:
    from collections.abc import Callable

    from wildfire_ros.dds.clock import Clock
    from wildfire_ros.dds.context import Context

_ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any


def check_message_type(msg_type: Any) -> None:
    """Reject classes that are not generated ROS message classes (e.g. rclpy's)."""
    if not hasattr(msg_type, "_ros_type") or not hasattr(msg_type, "__idl__"):
        raise TypeError(
            f"{msg_type!r} is not a message class of the DDS backend: "
            "use wildfire_ros.runtime.get_message('pkg/msg/Type')"
        )


class Publisher:
    """Writes messages of one type to ``rt/<topic>`` (``rclpy.publisher.Publisher``)."""

    def __init__(self, context: Context, msg_type: Any, topic_name: str, qos: QoSProfile) -> None:
        check_message_type(msg_type)
        self.msg_type = msg_type
        self.topic_name = topic_name
        self.qos_profile = qos
        topic = context.topic(topic_name, msg_type)
        self._writer: DataWriter[Any] | None = DataWriter(
            context.participant, topic, qos=to_cyclone(qos)
        )

    def publish(self, msg: Any) -> None:
        """Send one message (serialized as XCDR1 CDR)."""
        if not isinstance(msg, self.msg_type):
            raise TypeError(
                f"publisher of {self.topic_name} expects {self.msg_type._ros_type}, "
                f"got {type(msg).__name__}"
            )
        if self._writer is None:
            raise RuntimeError(f"publisher of {self.topic_name} was destroyed")
        self._writer.write(msg)

    def get_subscription_count(self) -> int:
        """Number of matched subscriptions (any process)."""
        return 0 if self._writer is None else len(self._writer.get_matched_subscriptions())

    def wait_for_all_acked(self, timeout: Any = None) -> bool:
        """Block until every matched reliable reader acknowledged what was written.

        ``timeout`` is a :class:`~wildfire_ros.dds.clock.Duration` (None: forever), as in
        rclpy. Best-effort publishers return True at once.
        """
        if self._writer is None or self.qos_profile.reliability != ReliabilityPolicy.RELIABLE:
            return True
        nanoseconds = None if timeout is None else int(timeout.nanoseconds)
        limit = duration(infinite=True) if nanoseconds is None or nanoseconds < 0 else nanoseconds
        try:
            return bool(self._writer.wait_for_acks(limit))
        except DDSException:
            return False

    def destroy(self) -> None:
        """Delete the DDS writer."""
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.__del__()


class Subscription:
    """Reads ``rt/<topic>``; the executor calls ``callback(msg)`` (``rclpy.subscription``)."""

    def __init__(
        self,
        context: Context,
        msg_type: Any,
        topic_name: str,
        callback: Callable[[Any], Any],
        qos: QoSProfile,
        raw: bool = False,
    ) -> None:
        check_message_type(msg_type)
        self.msg_type = msg_type
        self.topic_name = topic_name
        self.callback = callback
        self.qos_profile = qos
        self.raw = raw
        topic = context.topic(topic_name, msg_type)
        self._reader: DataReader[Any] | None = DataReader(
            context.participant, topic, qos=to_cyclone(qos)
        )
        self.condition: ReadCondition | None = ReadCondition(self._reader, _ANY_STATE)

    def take_serialized(self) -> tuple[bytes, int] | None:
        """One pending sample as (CDR bytes, source timestamp ns), or None."""
        reader = self._reader
        while reader is not None:
            taken = ddspy_take(reader._ref, _ANY_STATE, 1)
            if isinstance(taken, int) or not taken:
                return None
            data, info = taken[0]
            if info.valid_data:  # skip dispose/unregister notifications of departed writers
                return data, info.source_timestamp
        return None

    def take(self) -> Any:
        """One pending message (deserialized unless ``raw``), or None."""
        taken = self.take_serialized()
        if taken is None:
            return None
        return taken[0] if self.raw else self.msg_type.deserialize(taken[0])

    def get_publisher_count(self) -> int:
        """Number of matched publishers (any process)."""
        return 0 if self._reader is None else len(self._reader.get_matched_publications())

    def destroy(self) -> None:
        """Delete the DDS reader."""
        reader, self._reader = self._reader, None
        condition, self.condition = self.condition, None
        if condition is not None:
            condition.__del__()
        if reader is not None:
            reader.__del__()


class Timer:
    """Calls ``callback()`` every period of its clock (``rclpy.timer.Timer``).

    On a ROS clock in sim time the timer follows ``/clock``: it becomes ready when sim time
    reaches its next call time; missed periods are skipped (as rcl does), and a backwards
    jump of the clock restarts the timer from the new time.
    """

    def __init__(self, callback: Callable[[], Any], period_ns: int, clock: Clock) -> None:
        if period_ns <= 0:
            raise ValueError(f"timer period must be > 0 s, got {period_ns / 1e9} s")
        self.callback = callback
        self.timer_period_ns = int(period_ns)
        self.clock = clock
        self._canceled = False
        self._next_call_ns = clock.now().nanoseconds + self.timer_period_ns

    def is_canceled(self) -> bool:
        """True after ``cancel``."""
        return self._canceled

    def cancel(self) -> None:
        """Stop calling back until ``reset``."""
        self._canceled = True

    def reset(self) -> None:
        """Restart the period from now."""
        self._canceled = False
        self._next_call_ns = self.clock.now().nanoseconds + self.timer_period_ns

    def time_until_next_call(self) -> int | None:
        """Nanoseconds until the next call (None when canceled)."""
        if self._canceled:
            return None
        return self._next_call_ns - self.clock.now().nanoseconds

    @property
    def follows_sim_time(self) -> bool:
        """True when time comes from ``/clock`` (wake-ups then come from messages)."""
        return self.clock.ros_time_is_active

    def is_ready(self) -> bool:
        """Due now; also realigns after a backwards jump of the clock."""
        if self._canceled:
            return False
        now = self.clock.now().nanoseconds
        if now < self._next_call_ns - self.timer_period_ns:
            self._next_call_ns = now + self.timer_period_ns
        return now >= self._next_call_ns

    def call(self) -> None:
        """Advance the schedule past now, then run the callback."""
        now = self.clock.now().nanoseconds
        missed = (now - self._next_call_ns) // self.timer_period_ns + 1
        self._next_call_ns += max(1, missed) * self.timer_period_ns
        self.callback()

    def destroy(self) -> None:
        """Never call back again."""
        self._canceled = True


__all__ = ["Publisher", "Subscription", "Timer", "check_message_type"]
