"""Decision deadlines of the 10 Hz loop: per-decision timing and the real-time slots.

An agent's decision must end within its 100 ms slot; :class:`DeadlineStats` counts the ones
that did not and says how the agent is doing (its ``/diagnostics`` status), and
:func:`next_slot_start` keeps the real-time slots on the wall clock.
"""

from __future__ import annotations

from wildfire_agent.dynamics import DECISION_PERIOD_S
from wildfire_msgs_py.codecs import NodeStatus
from wildfire_msgs_py.contract import DEADLINE_STATUS

PERIOD_S = DECISION_PERIOD_S
"""The decision period: one slot."""
DEADLINE_EVERY_DECISIONS = 10
"""Deadline statistics go out at 1 Hz: every message costs each node a publish."""


class DeadlineStats:
    """Decision-time statistics of the 10 Hz loop."""

    def __init__(self) -> None:
        self.decisions = 0
        self.missed = 0
        self.compute_s_total = 0.0
        self.compute_s_max = 0.0
        self.late_s_max = 0.0

    def add(self, compute_s: float, late_s: float) -> None:
        self.decisions += 1
        self.compute_s_total += compute_s
        self.compute_s_max = max(self.compute_s_max, compute_s)
        self.late_s_max = max(self.late_s_max, late_s)
        if late_s + compute_s > PERIOD_S:
            self.missed += 1

    def level(self) -> str:
        """Diagnostic level: OK under 1 % missed deadlines, WARN under 10 %, else ERROR."""
        fraction = self.missed / max(self.decisions, 1)
        return "OK" if fraction < 0.01 else "WARN" if fraction < 0.1 else "ERROR"

    def as_dict(self) -> dict[str, float | int]:
        return {
            "decisions": self.decisions,
            "missed": self.missed,
            "missed_fraction": self.missed / max(self.decisions, 1),
            "compute_ms_mean": 1e3 * self.compute_s_total / max(self.decisions, 1),
            "compute_ms_max": 1e3 * self.compute_s_max,
            "late_ms_max": 1e3 * self.late_s_max,
        }

    def node_status(self, name_tag: str) -> NodeStatus:
        stats = self.as_dict()
        return NodeStatus(
            f"{name_tag}/agent: {DEADLINE_STATUS}",
            name_tag,
            self.level(),
            f"{stats['missed']} of {stats['decisions']} decisions missed their 100 ms slot",
            dict(stats),
        )


def next_slot_start(slot_start: float, now_s: float, period_s: float = PERIOD_S) -> float:
    """Start of the next decision slot after ``now_s``.

    Slots follow the wall clock: a late decision does not shift the next slot, and a
    decision that overran several slots skips them instead of queueing decisions.
    """
    return slot_start + period_s * max(1, int((now_s - slot_start) // period_s))


__all__ = ["DEADLINE_EVERY_DECISIONS", "PERIOD_S", "DeadlineStats", "next_slot_start"]
