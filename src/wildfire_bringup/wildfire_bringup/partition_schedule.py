"""Cutting hosts off and healing them on schedule during a run (``wildfire run --partition``).

A cut host's nodes are *unreachable*, not dead (only a process that exits is), and the run goes
on: :class:`PartitionSchedule` applies the cuts and heals of ``RunSpec.partitions``
(:mod:`wildfire_testbed.netfaults`), logs them and, from the run monitor's receipt times, works
out when each unreachable node was heard again.
"""

from __future__ import annotations

import sys
from typing import Any

from wildfire_bringup.monitor_node import RunMonitorNode
from wildfire_testbed.hosts import LAUNCHER, VirtualHosts
from wildfire_testbed.netfaults import Partition, PartitionRecord


class PartitionSchedule:
    """Cuts and heals hosts on schedule (seconds of wall time after the first tick) and records
    what the run monitor heard meanwhile."""

    def __init__(
        self, partitions: tuple[Partition, ...], network: VirtualHosts, monitor: RunMonitorNode
    ) -> None:
        self.network = network
        self.monitor = monitor
        self.records = [
            PartitionRecord(p, network.hosts[p.host].namespace, self._unreachable(p.host))
            for p in partitions
        ]
        self._heal_times: dict[int, float] = {}

    def _unreachable(self, index: int) -> tuple[str, ...]:
        """The nodes the launcher cannot hear while host ``index`` is cut off."""
        own = self.network.host_of(LAUNCHER)
        cut = self.network.hosts[index]
        if cut == own:
            return tuple(n for h in self.network.hosts if h != own for n in h.nodes)
        return tuple(n for n in cut.nodes if n != LAUNCHER)

    @property
    def extra_time_s(self) -> float:
        """Wall time the cuts may add to a lockstep run (it waits through them)."""
        return sum(r.partition.duration_s for r in self.records)

    def step(self, flight_s: float, now: float) -> None:
        """Apply every cut and heal that is due at ``flight_s`` after the first tick."""
        for i, record in enumerate(self.records):
            partition = record.partition
            if record.cut_at_s is None and flight_s >= partition.start_s:
                self.network.cut(partition.host)
                record.cut_at_s = flight_s
                record.belief_stamps = (self.monitor.belief_stamp, -1, -1)
                print(
                    f"wildfire run: host {partition.host} ({record.namespace}) cut off at "
                    f"{flight_s:.1f} s for {partition.duration_s:g} s; unreachable, not dead: "
                    f"{', '.join(record.unreachable) or 'no node'}",
                    file=sys.stderr,
                )
            elif record.healed_at_s is None and flight_s >= partition.end_s:
                self.heal(i, flight_s, now)

    def heal(self, i: int, flight_s: float, now: float) -> None:
        record = self.records[i]
        self.network.heal(record.partition.host)
        record.healed_at_s = flight_s
        self._heal_times[i] = now
        at_cut = record.belief_stamps[0] if record.belief_stamps else -1
        record.belief_stamps = (at_cut, self.monitor.belief_stamp, -1)
        print(
            f"wildfire run: host {record.partition.host} ({record.namespace}) healed at "
            f"{flight_s:.1f} s",
            file=sys.stderr,
        )

    def finish(self, flight_s: float, now: float) -> None:
        """Heal what is still cut (the run ended first) and work out when nodes came back."""
        for i, record in enumerate(self.records):
            if record.cut_at_s is not None and record.healed_at_s is None:
                self.heal(i, flight_s, now)
            if i not in self._heal_times:
                continue
            healed = self._heal_times[i]
            record.heard_again_after_s = {
                node: self.monitor.first_heard_after(node, healed) for node in record.unreachable
            }
            for node in record.unreachable:
                after = record.heard_again_after_s[node]
                record.heard_again_after_s[node] = None if after is None else after - healed
            if record.belief_stamps is not None:
                record.belief_stamps = (*record.belief_stamps[:2], self.monitor.belief_stamp)
            heard = ", ".join(
                f"{node} after {after:.2f} s" if after is not None else f"{node} never"
                for node, after in record.heard_again_after_s.items()
            )
            print(
                f"wildfire run: after the heal of host {record.partition.host}, heard again "
                f"from {heard or 'no node'}",
                file=sys.stderr,
            )

    def summary(self) -> list[dict[str, Any]]:
        return [record.summary() for record in self.records]


__all__ = ["PartitionSchedule"]
