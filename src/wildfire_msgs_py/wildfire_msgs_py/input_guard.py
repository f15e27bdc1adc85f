"""What a node does with input it must not trust: drop it, count it, say so now and then.

Any participant of an open DDS domain can publish on our topics (see ``docs/deployment.md``,
"Security"), so every subscription of a node runs its callback through an
:class:`InputGuard`. A callback rejects a message by raising :class:`RejectedMessage` (the
checks of :mod:`wildfire_msgs_py.wire_checks` and :class:`TickInbox` do); the guard drops it,
counts it per topic and reason, and logs at most one line per topic every ``log_period_s``,
so a flood of garbage can neither stop the node nor drown its log. The counts go out in the
node's ``/diagnostics`` status (:meth:`InputGuard.status`).

Plain Python, no ROS import: the nodes and the tests use the same code.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable
from enum import StrEnum
from typing import Any, Generic, TypeVar

from wildfire_msgs_py.codecs import NodeStatus
from wildfire_msgs_py.errors import MessageFieldError

INPUT_STATUS = "input validation"
"""Name suffix of every node's input-validation status on ``/diagnostics``."""


class DropReason(StrEnum):
    """Why a message was dropped (the counter key in the node's diagnostics)."""

    MALFORMED = "malformed"
    """Sizes, layout or encoding do not fit the topic."""
    OUT_OF_RANGE = "out of range"
    """Values that are not finite or lie outside what the model allows."""
    WRONG_FRAME = "wrong frame"
    """``header.frame_id`` (or the reporter name) is not the topic's."""
    STALE = "stale"
    """A stamp older than what the node has already used (a replay)."""
    FUTURE = "future"
    """A stamp further ahead than any honest sender can be."""
    DUPLICATE = "duplicate"
    """A second message for a stamp already received: the first one counts."""
    RATE_LIMITED = "rate limited"
    """A request answered too recently to answer again."""
    IMPERSONATION = "impersonation"
    """A message that claims to come from another sender than its topic's (another aircraft)."""


class RejectedMessage(MessageFieldError):
    """A received message that fails validation, with the reason it is dropped."""

    def __init__(self, reason: DropReason, detail: str) -> None:
        super().__init__(f"{reason.value}: {detail}")
        self.reason = reason


# Decoding hostile bytes can fail anywhere in numpy or the message classes; whatever it
# raises, the message is malformed and the node goes on.
_DECODE_ERRORS = (MessageFieldError, ValueError, TypeError, IndexError, KeyError, OverflowError)


class InputGuard:
    """Drops, counts and (rate-limited) logs the messages a node rejects."""

    def __init__(
        self,
        warn: Callable[[str], Any],
        log_period_s: float = 5.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.warn = warn
        self.log_period_s = log_period_s
        self.clock = clock
        self.dropped: Counter[tuple[str, DropReason]] = Counter()
        self._last_log: dict[str, float] = {}
        self._unlogged: Counter[str] = Counter()

    @property
    def total(self) -> int:
        return sum(self.dropped.values())

    def drop(self, topic: str, error: BaseException) -> None:
        """Count ``error``'s message on ``topic``; log it unless that topic logged recently."""
        reason = error.reason if isinstance(error, RejectedMessage) else DropReason.MALFORMED
        self.dropped[topic, reason] += 1
        now = self.clock()
        last = self._last_log.get(topic)
        if last is not None and now - last < self.log_period_s:
            self._unlogged[topic] += 1
            return
        self._last_log[topic] = now
        more = self._unlogged.pop(topic, 0)
        suffix = f" ({more} more dropped since the last report)" if more else ""
        self.warn(f"dropped a message on {topic}: {error}{suffix}")

    def guarded(self, topic: str, callback: Callable[[Any], None]) -> Callable[[Any], None]:
        """``callback`` with every rejection and decoding failure turned into a drop."""

        def guarded_callback(msg: Any) -> None:
            try:
                callback(msg)
            except _DECODE_ERRORS as error:
                self.drop(topic, error)

        return guarded_callback

    def counts(self) -> dict[str, int]:
        """``"<topic> <reason>"`` -> messages dropped, for diagnostics values."""
        return {f"{topic} {reason.value}": n for (topic, reason), n in sorted(self.dropped.items())}

    def status(self, node: str, hardware_id: str) -> NodeStatus:
        """The node's input-validation status: WARN once anything was dropped."""
        total = self.total
        return NodeStatus(
            f"{node}: {INPUT_STATUS}",
            hardware_id,
            "WARN" if total else "OK",
            f"{total} received messages dropped",
            {"dropped": total, **self.counts()},
        )


T = TypeVar("T")


class TickInbox(Generic[T]):
    """Messages of one sender by stamp: the first one per stamp counts, replays are refused.

    ``accept`` raises :class:`RejectedMessage` for a stamp below ``floor`` (already used:
    stale), above ``ceiling`` (no honest sender runs that far ahead), off the ``period`` grid,
    or already held (duplicate). Callers move ``floor``/``ceiling`` as their clock advances
    and :meth:`discard_below` what they no longer need, so the inbox stays small under a flood.
    """

    def __init__(self, period_ns: int | None = None) -> None:
        self.period_ns = period_ns
        self.items: dict[int, T] = {}
        self.floor = 0
        self.ceiling: int | None = None

    def accept(self, stamp: int, value: T) -> None:
        if stamp < self.floor:
            raise RejectedMessage(DropReason.STALE, f"stamp {stamp} ns < {self.floor} ns")
        if self.ceiling is not None and stamp > self.ceiling:
            raise RejectedMessage(DropReason.FUTURE, f"stamp {stamp} ns > {self.ceiling} ns")
        if self.period_ns is not None and stamp % self.period_ns:
            raise RejectedMessage(
                DropReason.OUT_OF_RANGE, f"stamp {stamp} ns is not a tick of {self.period_ns} ns"
            )
        if stamp in self.items:
            raise RejectedMessage(DropReason.DUPLICATE, f"stamp {stamp} ns already received")
        self.items[stamp] = value

    def get(self, stamp: int) -> T | None:
        return self.items.get(stamp)

    def keep_newest(self, count: int) -> None:
        """Keep the ``count`` newest stamps; older ones are forgotten and refused."""
        if len(self.items) > count:
            self.discard_below(sorted(self.items)[-count])

    def latest(self) -> tuple[int, T] | None:
        if not self.items:
            return None
        stamp = max(self.items)
        return stamp, self.items[stamp]

    def discard_below(self, stamp: int) -> None:
        """Forget stamps below ``stamp`` and refuse them from now on."""
        self.floor = max(self.floor, stamp)
        for old in [s for s in self.items if s < stamp]:
            del self.items[old]

    def __contains__(self, stamp: int) -> bool:
        return stamp in self.items

    def __len__(self) -> int:
        return len(self.items)


def check_status_tick(tick: int, last_tick: int, lockstep: bool, realtime_step: int) -> None:
    """Refuse an episode status whose tick no honest fire simulator announces next.

    Lockstep: ticks are announced one by one from 0 and the fire simulator waits for every
    node, so a status may repeat an earlier tick (a replay, harmless) but never skip one.
    Real time: statuses come every fire step, so one more than ``realtime_step`` ticks past
    the last one seen is refused; the first is taken as it comes (a restarted node joins a
    running episode).
    """
    if lockstep:
        if tick > last_tick + 1:
            raise RejectedMessage(DropReason.FUTURE, f"episode tick {tick} after tick {last_tick}")
    elif last_tick >= 0 and tick > last_tick + realtime_step:
        raise RejectedMessage(DropReason.FUTURE, f"episode tick {tick} after tick {last_tick}")


__all__ = [
    "INPUT_STATUS",
    "DropReason",
    "InputGuard",
    "RejectedMessage",
    "TickInbox",
    "check_status_tick",
]
