"""Limited radio links in real time: the tick of each slot, and which heard ticks to refuse.

In lockstep the episode status names every tick. In real time it comes once a fire step
(2.5 s), and an agent decides once per 100 ms slot of its own clock. A radio message needs a
tick all the same: the links' draw, the outage window, the delay and the replica's visit keys
are addressed by it (``wildfire_belief.radio``). :class:`RadioTicks` gives each slot the
newest status tick plus the whole decision periods since that status arrived, on the node
clock, and never the same tick twice. Agents on one clock (one host, or hosts whose clocks
agree) thus stamp a slot with the same tick, within a tick of network latency.

It also refuses, per peer, a message whose tick is not newer than one already taken from
that peer (a replay or a duplicate) or that lies further ahead of our own tick than an honest
peer can be (:data:`~wildfire_sim.episode.AHEAD_TICKS`).
"""

from __future__ import annotations

from collections.abc import Iterable

from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_sim.episode import AHEAD_TICKS, DECISION_PERIOD_NS


class RadioTicks:
    """Slot ticks of one real-time agent and the newest tick taken from each of ``peers``."""

    def __init__(self, peers: Iterable[int]) -> None:
        self.sent = 0
        """The tick of the latest slot (0: none yet; tick 0 is the start, sent by nobody)."""
        self.anchor: tuple[int, int] | None = None
        """(tick, node clock ns) of the newest episode status received."""
        self.heard = {j: 0 for j in peers}

    def on_status(self, tick: int, now_ns: int) -> None:
        """The episode status of ``tick`` arrived at ``now_ns``."""
        if self.anchor is None or tick > self.anchor[0]:
            self.anchor = (tick, now_ns)

    def next(self, now_ns: int) -> int:
        """The tick of the slot that starts at ``now_ns``: always newer than the last one."""
        estimate = 0
        if self.anchor is not None:
            tick, at_ns = self.anchor
            estimate = tick + max(0, now_ns - at_ns) // DECISION_PERIOD_NS
        self.sent = max(self.sent + 1, estimate)
        return self.sent

    def take(self, j: int, tick: int) -> None:
        """Peer ``j``'s message of ``tick``: refused unless newer than the last one taken."""
        if tick <= self.heard[j]:
            raise RejectedMessage(
                DropReason.STALE, f"radio tick {tick} of aircraft {j}, {self.heard[j]} taken"
            )
        if tick > self.sent + AHEAD_TICKS:
            raise RejectedMessage(
                DropReason.FUTURE, f"radio tick {tick} of aircraft {j}, ours is {self.sent}"
            )
        self.heard[j] = tick


__all__ = ["RadioTicks"]
