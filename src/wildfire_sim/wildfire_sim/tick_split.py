"""Where a lockstep tick's wall time goes, as the fire simulator sees its barrier.

A lockstep tick runs: the fire simulator announces it (status, then ``/clock``); every agent
decides and publishes; the aggregator merges the visits and publishes the belief; each
reporter acknowledges; once the last acknowledgement is in, the fire simulator steps the fire
when due and announces the next tick. :class:`TickSplit` takes the wall time of each
announcement and acknowledgement and reports, per tick on average:

* ``fire_ms``: from the last acknowledgement to the next announcement, the barrier's own
  part (the fire step, the maps and the status, in the fire simulator);
* ``nodes_ms``: from the announcement to the last acknowledgement (transport, every node's
  work and its acknowledgement);
* ``agents_ms``: the slowest agent's acknowledgement after the announcement, and for every
  other reporter (the aggregator ``belief_aggregator``, the run monitor ``wildfire_run``)
  its own, as ``<reporter>_ms``: who the barrier waits for.

The roles overlap in time (the aggregator waits for the agents' visits), so the lags are not
summed; ``fire_ms + nodes_ms`` is the whole tick.
"""

from __future__ import annotations

from collections import defaultdict

AGENT_PREFIX = "uav"


class TickSplit:
    """Running sums of one lockstep episode's tick split (see the module docstring)."""

    def __init__(self) -> None:
        self.announced_s: float | None = None
        self.last_ack_s: float | None = None
        """The current tick's latest acknowledgement (the one that completes it, once all)."""
        self.ticks = 0
        self.fire_s = 0.0
        self.nodes_s = 0.0
        self.lag_s: defaultdict[str, float] = defaultdict(float)
        self.tick_lag_s: dict[str, float] = {}

    def announced(self, now_s: float) -> None:
        """The next tick is announced: close the one before."""
        if self.announced_s is not None and self.last_ack_s is not None:
            self.ticks += 1
            self.nodes_s += self.last_ack_s - self.announced_s
            self.fire_s += now_s - self.last_ack_s
            for role, lag in self.tick_lag_s.items():
                self.lag_s[role] += lag
        self.announced_s, self.last_ack_s, self.tick_lag_s = now_s, None, {}

    def acked(self, reporter: str, now_s: float) -> None:
        """``reporter`` acknowledged the current tick."""
        if self.announced_s is None:
            return
        self.last_ack_s = now_s
        role = "agents" if reporter.startswith(AGENT_PREFIX) else reporter
        lag = now_s - self.announced_s
        self.tick_lag_s[role] = max(self.tick_lag_s.get(role, 0.0), lag)

    def values(self) -> dict[str, float]:
        """Mean milliseconds per tick, by part (empty before the first whole tick)."""
        if not self.ticks:
            return {}
        scale = 1e3 / self.ticks
        out = {"split_ticks": float(self.ticks)}
        out |= {"split_fire_ms": self.fire_s * scale, "split_nodes_ms": self.nodes_s * scale}
        out |= {f"split_{role}_ms": lag * scale for role, lag in sorted(self.lag_s.items())}
        return out


def tick_split_ms(values: dict[str, float]) -> dict[str, float]:
    """``split_*`` status values -> ``{"ticks": n, "fire": ms, "nodes": ms, ...}`` (summaries)."""
    return {
        key.removeprefix("split_").removesuffix("_ms"): round(value, 3)
        for key, value in values.items()
        if key.startswith("split_")
    }


__all__ = ["TickSplit", "tick_split_ms"]
