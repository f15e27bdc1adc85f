"""Network faults of ``wildfire run --hosts K``: link impairment (``--netem``) and partitions.

* :class:`NetemSpec` — ``delay TIME [JITTER] loss PCT%``, the subset of ``tc-netem(8)`` the run
  applies on every host's link. Where the kernel has ``sch_netem`` it is exactly that qdisc on
  each host's ``wf0`` (egress, so a frame between two hosts is impaired once, by its sender).
  Where it has not (some VM and container kernels build no ``sch_netem``), the bridge namespace
  runs :mod:`wildfire_testbed.netem_switch` instead of the kernel bridge: a user-space switch
  that delays and drops each frame by the same rule. The run's summary says which one it used.
* :class:`Partition` — ``HOST:START_S:DURATION_S``: the host's bridge port goes down ``START_S``
  seconds of wall time after the first tick and up again ``DURATION_S`` later. The host keeps
  its processes, its address and its loopback; it only loses the segment, as an aircraft that
  flies out of radio range.

Every change happens inside the run's own namespaces (``ip -n``/``tc -n``), never in the root one.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

_TIME = re.compile(r"^(\d+(?:\.\d+)?)(us|ms|s)$")
_PERCENT = re.compile(r"^(\d+(?:\.\d+)?)%$")
_TIME_UNITS_MS = {"us": 1e-3, "ms": 1.0, "s": 1e3}
NETEM_EXAMPLE = "'delay 20ms 10ms loss 2%'"
MAX_DELAY_MS = 10_000.0


class FaultSpecError(ValueError):
    """A fault option that cannot be applied; the message says why, in one line."""


def _time_ms(text: str) -> float | None:
    match = _TIME.match(text)
    return None if match is None else float(match.group(1)) * _TIME_UNITS_MS[match.group(2)]


@dataclass(frozen=True)
class NetemSpec:
    """One-way impairment of every host's link: uniform delay in ``delay ± jitter``, then loss."""

    delay_ms: float = 0.0
    jitter_ms: float = 0.0
    loss_percent: float = 0.0

    @classmethod
    def parse(cls, text: str) -> NetemSpec:
        """``delay TIME [JITTER]`` and/or ``loss PCT%``, as ``tc-netem(8)`` writes them."""
        words = text.split()
        fields: dict[str, float] = {}
        i = 0
        while i < len(words):
            word = words[i]
            if word == "delay" and "delay_ms" not in fields and i + 1 < len(words):
                delay = _time_ms(words[i + 1])
                if delay is None:
                    raise FaultSpecError(f"delay {words[i + 1]!r}: expected a time like 20ms")
                fields["delay_ms"] = delay
                i += 2
                jitter = _time_ms(words[i]) if i < len(words) else None
                if jitter is not None:
                    fields["jitter_ms"] = jitter
                    i += 1
            elif word == "loss" and "loss_percent" not in fields and i + 1 < len(words):
                match = _PERCENT.match(words[i + 1])
                if match is None:
                    raise FaultSpecError(f"loss {words[i + 1]!r}: expected a percentage like 2%")
                fields["loss_percent"] = float(match.group(1))
                i += 2
            else:
                raise FaultSpecError(f"unexpected {word!r}: expected {NETEM_EXAMPLE}")
        if not fields:
            raise FaultSpecError(f"empty: expected {NETEM_EXAMPLE}")
        spec = cls(**fields)
        spec.check()
        return spec

    def check(self) -> None:
        if not 0.0 <= self.delay_ms <= MAX_DELAY_MS:
            raise FaultSpecError(f"delay {self.delay_ms:g} ms: at most {MAX_DELAY_MS:g} ms")
        if self.jitter_ms > self.delay_ms:
            raise FaultSpecError(
                f"jitter {self.jitter_ms:g} ms exceeds the delay {self.delay_ms:g} ms"
            )
        if not 0.0 <= self.loss_percent < 100.0:
            raise FaultSpecError(
                f"loss {self.loss_percent:g}%: expected 0 to 99.99% (--partition cuts a host off)"
            )

    def tc_arguments(self) -> list[str]:
        """The ``tc qdisc ... netem`` arguments of this impairment."""
        arguments = ["delay", f"{self.delay_ms:g}ms"]
        if self.jitter_ms:
            arguments.append(f"{self.jitter_ms:g}ms")
        return [*arguments, "loss", f"{self.loss_percent:g}%"]

    def describe(self) -> str:
        return " ".join(self.tc_arguments())


@dataclass(frozen=True)
class Partition:
    """Host ``host`` cut off from the bridge over ``[start_s, start_s + duration_s)`` after the
    first tick (wall time)."""

    host: int
    start_s: float
    duration_s: float

    @classmethod
    def parse(cls, text: str, n_hosts: int) -> Partition:
        parts = text.split(":")
        try:
            if len(parts) != 3:
                raise ValueError
            host, start_s, duration_s = int(parts[0]), float(parts[1]), float(parts[2])
        except ValueError:
            expected = "expected HOST:START_S:DURATION_S, e.g. 1:5:10"
            raise FaultSpecError(f"{text!r}: {expected}") from None
        if not 0 <= host < n_hosts:
            raise FaultSpecError(f"{text!r}: host {host} is not one of 0..{n_hosts - 1}")
        if not (0.0 <= start_s < 1e5 and 0.0 < duration_s < 1e5):
            raise FaultSpecError(f"{text!r}: expected START_S >= 0 and DURATION_S > 0")
        return cls(host, start_s, duration_s)

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s


def check_partitions(partitions: list[Partition]) -> None:
    """Two cuts of one host may not overlap (the first heal would end the second cut early)."""
    for i, first in enumerate(partitions):
        for second in partitions[i + 1 :]:
            overlap = first.start_s < second.end_s and second.start_s < first.end_s
            if first.host == second.host and overlap:
                raise FaultSpecError(f"two overlapping cuts of host {first.host}")


@dataclass
class PartitionRecord:
    """What happened during one partition, for the run's summary."""

    partition: Partition
    namespace: str
    unreachable: tuple[str, ...]
    """The nodes the launcher's host could not reach during the cut."""
    cut_at_s: float | None = None
    healed_at_s: float | None = None
    heard_again_after_s: dict[str, float | None] | None = None
    """Per unreachable node: seconds from the heal to its first message at the run monitor."""
    belief_stamps: tuple[int, int, int] | None = None
    """The monitor's belief stamp (ns) at the cut, at the heal and at the end of the run."""

    def summary(self) -> dict[str, Any]:
        return {
            "host": self.partition.host,
            "namespace": self.namespace,
            "planned_start_s": self.partition.start_s,
            "planned_duration_s": self.partition.duration_s,
            "cut_at_s": self.cut_at_s,
            "healed_at_s": self.healed_at_s,
            "unreachable_nodes": list(self.unreachable),
            "heard_again_after_heal_s": self.heard_again_after_s or {},
            "belief_stamp_ns_at_cut_heal_end": list(self.belief_stamps or ()),
        }


__all__ = [
    "FaultSpecError",
    "NetemSpec",
    "Partition",
    "PartitionRecord",
    "check_partitions",
]
