"""Backend-neutral graph helpers: QoS that matches whoever publishes a topic.

A subscription only matches a publisher whose QoS offers at least what it requests
(a RELIABLE reader needs RELIABLE writers, a TRANSIENT_LOCAL reader TRANSIENT_LOCAL writers).
Tools that attach to an unknown system (``topic echo``, ``bag record``) therefore adapt to the
publishers found in the graph, as ``ros2 topic echo`` and ``ros2 bag record`` do.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from wildfire_msgs_py.contract import spec_for


class EndpointInfo(NamedTuple):
    """One publisher or subscription of a topic, as ``ros2 topic info -v`` lists it."""

    kind: str
    """``PUBLISHER`` or ``SUBSCRIPTION``."""
    node: str
    """Fully qualified node name, or the DDS participant where the node is not known."""
    reliability: str
    durability: str
    history: str
    """``KEEP_LAST (depth)`` or ``KEEP_ALL``."""


def endpoint_infos(node: Any, topic: str) -> list[EndpointInfo]:
    """Every endpoint of ``topic`` in the graph with its QoS, on either backend."""
    from wildfire_ros.runtime import BACKEND, HistoryPolicy

    if BACKEND == "dds":
        return [
            EndpointInfo(
                "PUBLISHER" if e.kind == "publication" else "SUBSCRIPTION",
                f"participant {e.participant}",
                e.qos["reliability"],
                e.qos["durability"],
                e.qos["history"],
            )
            for e in node.context.graph().endpoints(topic)
        ]
    infos = []
    for kind, found in (
        ("PUBLISHER", node.get_publishers_info_by_topic(topic)),
        ("SUBSCRIPTION", node.get_subscriptions_info_by_topic(topic)),
    ):
        for info in found:
            qos = info.qos_profile
            history = (
                "KEEP_ALL" if qos.history == HistoryPolicy.KEEP_ALL else f"KEEP_LAST ({qos.depth})"
            )
            name = info.node_name
            if name and name != "_NODE_NAME_UNKNOWN_":
                name = f"{info.node_namespace.rstrip('/')}/{name}"
            infos.append(
                EndpointInfo(kind, name, qos.reliability.name, qos.durability.name, history)
            )
    return infos


def publisher_qos_flags(node: Any, topic: str) -> tuple[bool, bool] | None:
    """(all reliable, all transient-local) over the topic's publishers; None when none known."""
    from wildfire_ros.runtime import BACKEND, DurabilityPolicy, ReliabilityPolicy

    if BACKEND == "dds":
        publishers = [
            e.qos for e in node.context.graph().endpoints(topic) if e.kind == "publication"
        ]
        if not publishers:
            return None
        return (
            all(q["reliability"] == "RELIABLE" for q in publishers),
            all(q["durability"] == "TRANSIENT_LOCAL" for q in publishers),
        )
    infos = node.get_publishers_info_by_topic(topic)
    if not infos:
        return None
    return (
        all(i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos),
        all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos),
    )


def adapted_qos(node: Any, topic: str, depth: int = 10) -> Any:
    """A subscription QoS matching every current publisher of ``topic``.

    Falls back to the contract's QoS for topics of the system, else reliable/volatile.
    """
    from wildfire_ros.runtime import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    flags = publisher_qos_flags(node, topic)
    if flags is None:
        spec = spec_for(topic)
        flags = (spec.qos.reliable, spec.qos.transient_local) if spec else (True, False)
    reliable, latched = flags
    return QoSProfile(
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


__all__ = ["EndpointInfo", "adapted_qos", "endpoint_infos", "publisher_qos_flags"]
