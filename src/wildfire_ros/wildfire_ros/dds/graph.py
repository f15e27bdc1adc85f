"""Graph introspection from Cyclone's builtin topics (DCPSPublication / DCPSSubscription).

Only ROS topics (DDS topics ``rt/...`` with ``pkg::msg::dds_::Type_`` types) are reported, for
every participant of the domain, ours included, as ``ros2 topic list`` shows them.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import InstanceState, SampleState, ViewState

from wildfire_msgs_py.types import ros_type_name
from wildfire_ros.dds.qos import describe_cyclone

_ANY = SampleState.Any | ViewState.Any | InstanceState.Any


@dataclass(frozen=True)
class Endpoint:
    """One discovered publisher or subscription of a ROS topic."""

    kind: str
    """``publication`` or ``subscription``."""
    topic: str
    type: str
    participant: str
    qos: dict[str, str]


class GraphMonitor:
    """Keeps the set of alive ROS endpoints of the domain."""

    def __init__(self, participant: Any) -> None:
        self._lock = threading.Lock()
        self._readers = {
            "publication": BuiltinDataReader(participant, BuiltinTopicDcpsPublication),
            "subscription": BuiltinDataReader(participant, BuiltinTopicDcpsSubscription),
        }
        self._endpoints: dict[Any, Endpoint] = {}

    def _update(self) -> None:
        with self._lock:
            for kind, reader in self._readers.items():
                while True:
                    samples = reader.take(N=256)
                    if not samples:
                        break
                    for sample in samples:
                        info = getattr(sample, "sample_info", None)
                        key = getattr(sample, "key", None)
                        alive = info is None or (
                            info.valid_data and info.instance_state == InstanceState.Alive
                        )
                        if not alive:
                            self._endpoints.pop(key, None)
                            continue
                        topic_name = getattr(sample, "topic_name", "")
                        type_name = ros_type_name(getattr(sample, "type_name", ""))
                        if not topic_name.startswith("rt/") or type_name is None:
                            continue
                        self._endpoints[key] = Endpoint(
                            kind,
                            topic_name[2:],
                            type_name,
                            str(sample.participant_key),
                            describe_cyclone(sample.qos),
                        )

    def endpoints(self, topic: str | None = None) -> list[Endpoint]:
        """Alive endpoints, optionally of one topic."""
        self._update()
        with self._lock:
            return [e for e in self._endpoints.values() if topic is None or e.topic == topic]

    def topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        """Sorted ``(topic, [types])`` pairs."""
        topics: dict[str, set[str]] = {}
        for endpoint in self.endpoints():
            topics.setdefault(endpoint.topic, set()).add(endpoint.type)
        return [(name, sorted(types)) for name, types in sorted(topics.items())]

    def count(self, topic: str, kind: str) -> int:
        """Number of alive publications or subscriptions of a topic."""
        return sum(1 for e in self.endpoints(topic) if e.kind == kind)

    def close(self) -> None:
        """Delete the builtin readers."""
        for reader in self._readers.values():
            reader.__del__()
        self._readers = {}


__all__ = ["Endpoint", "GraphMonitor"]
