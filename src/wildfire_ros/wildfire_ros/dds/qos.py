"""rclpy-compatible QoS profiles and their mapping onto Cyclone DDS policies.

The mapping follows rmw_cyclonedds_cpp, so our endpoints match those of a real ROS 2 node:
RELIABLE -> Reliable (infinite max blocking time), BEST_EFFORT -> BestEffort, TRANSIENT_LOCAL and
VOLATILE durability, KEEP_LAST(depth) / KEEP_ALL history, and XCDR1 data representation.
"""

from __future__ import annotations

from enum import IntEnum
from typing import Any

from cyclonedds.core import Policy, Qos
from cyclonedds.util import duration


class ReliabilityPolicy(IntEnum):
    """As ``rclpy.qos.ReliabilityPolicy``."""

    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2


class DurabilityPolicy(IntEnum):
    """As ``rclpy.qos.DurabilityPolicy``."""

    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2


class HistoryPolicy(IntEnum):
    """As ``rclpy.qos.HistoryPolicy``."""

    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2


class QoSProfile:
    """As ``rclpy.qos.QoSProfile`` (reliability, durability, history and depth)."""

    def __init__(
        self,
        *,
        history: HistoryPolicy = HistoryPolicy.KEEP_LAST,
        depth: int | None = None,
        reliability: ReliabilityPolicy = ReliabilityPolicy.RELIABLE,
        durability: DurabilityPolicy = DurabilityPolicy.VOLATILE,
        **_ignored: Any,
    ) -> None:
        if history == HistoryPolicy.KEEP_LAST and depth is None:
            raise ValueError("QoSProfile with KEEP_LAST history needs a depth")
        if depth is not None and depth < 0:
            raise ValueError(f"QoS depth must be >= 0, got {depth}")
        self.history = HistoryPolicy(history)
        self.depth = int(depth or 0)
        self.reliability = ReliabilityPolicy(reliability)
        self.durability = DurabilityPolicy(durability)

    def __repr__(self) -> str:
        return (
            f"QoSProfile(history={self.history.name}, depth={self.depth}, "
            f"reliability={self.reliability.name}, durability={self.durability.name})"
        )

    def __eq__(self, other: object) -> bool:
        return isinstance(other, QoSProfile) and repr(self) == repr(other)

    __hash__ = None  # type: ignore[assignment]


#: As ``rclpy.qos.qos_profile_sensor_data``.
qos_profile_sensor_data = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
#: As ``rclpy.qos.qos_profile_system_default``.
qos_profile_system_default = QoSProfile(depth=10)


def as_profile(qos_or_depth: QoSProfile | int | Any) -> QoSProfile:
    """Accept a profile or a bare depth like rclpy's ``create_publisher``."""
    if isinstance(qos_or_depth, QoSProfile):
        return qos_or_depth
    if isinstance(qos_or_depth, int) and not isinstance(qos_or_depth, bool):
        return QoSProfile(depth=qos_or_depth)
    raise TypeError(f"expected a QoSProfile or a history depth, got {qos_or_depth!r}")


def to_cyclone(profile: QoSProfile) -> Qos:
    """The Cyclone DDS policies rmw_cyclonedds_cpp would use for ``profile``."""
    policies: list[Any] = [Policy.DataRepresentation(use_cdrv0_representation=True)]
    if profile.reliability == ReliabilityPolicy.BEST_EFFORT:
        policies.append(Policy.Reliability.BestEffort)
    else:
        policies.append(Policy.Reliability.Reliable(max_blocking_time=duration(infinite=True)))
    if profile.durability == DurabilityPolicy.TRANSIENT_LOCAL:
        policies.append(Policy.Durability.TransientLocal)
    else:
        policies.append(Policy.Durability.Volatile)
    if profile.history == HistoryPolicy.KEEP_ALL:
        policies.append(Policy.History.KeepAll)
    else:
        policies.append(Policy.History.KeepLast(max(1, profile.depth)))
    return Qos(*policies)


def describe_cyclone(qos: Any) -> dict[str, str]:
    """Reliability/durability/history of a discovered endpoint's Cyclone QoS, in ROS words."""
    result = {"reliability": "UNKNOWN", "durability": "UNKNOWN", "history": "UNKNOWN"}
    for policy in qos or ():
        text = repr(policy)
        if text.startswith("Policy.Reliability."):
            result["reliability"] = "BEST_EFFORT" if "BestEffort" in text else "RELIABLE"
        elif text.startswith("Policy.Durability."):
            result["durability"] = "TRANSIENT_LOCAL" if "TransientLocal" in text else "VOLATILE"
        elif text.startswith("Policy.History."):
            depth = getattr(policy, "depth", None)
            result["history"] = f"KEEP_LAST ({depth})" if depth is not None else "KEEP_ALL"
    return result


__all__ = [
    "DurabilityPolicy",
    "HistoryPolicy",
    "QoSProfile",
    "ReliabilityPolicy",
    "as_profile",
    "describe_cyclone",
    "qos_profile_sensor_data",
    "qos_profile_system_default",
    "to_cyclone",
]
