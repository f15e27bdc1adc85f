"""Recording the running system into a bag, as ``ros2 bag record`` does: :class:`BagRecorder`.

The recorder is one node of the active backend (rclpy or our Cyclone DDS layer) with raw
subscriptions: what it receives goes to a :class:`~wildfire_ros.bag.writer.BagWriter` as the
CDR bytes it arrived as, without deserialization. It records the given topics, or every topic
but :data:`BULKY_TOPICS`, including topics that appear later (the graph is polled). It
subscribes with a QoS adapted to the publishers seen (:func:`wildfire_ros.graph.adapted_qos`)
and stores the profiles they offer (:func:`offered_qos`) with each topic.

Log times are receive times on the system clock, as ``ros2 bag record`` does by default, or
on sim time (``use_sim_time``, as ``ros2 bag record --use-sim-time``): the latest ``/clock``
received, zero before the first one. ``wildfire run`` records its lockstep runs so, which lets
``wildfire bag play`` replay them at the pace they were simulated.

:mod:`wildfire_ros.runtime` (which applies the DDS network defaults and loads rclpy or
Cyclone) and :mod:`wildfire_ros.graph` are imported inside the functions that use them, so
reading and writing bags offline neither loads a ROS backend nor changes the DDS settings.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from wildfire_msgs_py import contract
from wildfire_msgs_py.contract import spec_for
from wildfire_msgs_py.errors import UnknownMessageTypeError
from wildfire_msgs_py.types import typestore
from wildfire_ros.bag.metadata import TIME_SOURCE_KEY, QosSummary
from wildfire_ros.bag.writer import BagWriter
from wildfire_ros.mcap_writer import DEFAULT_PRESET

if TYPE_CHECKING:
    from collections.abc import Iterable
    from pathlib import Path

#: Topics that recording *every* topic leaves out (``bag record -a``, ``wildfire run
#: --record``) unless asked for: the snapshots exist only for a restarted aggregator. (The
#: exact ages, sent whole every tick, were 93 % of a belief run's bytes; now whole once a fire
#: step, they are recorded: a belief delta needs its keyframe's ages to be read back.)
BULKY_TOPICS: tuple[str, ...] = (contract.BELIEF_SNAPSHOT.name,)


def offered_qos(node: Any, topic: str) -> list[QosSummary]:
    """One profile per current publisher of ``topic`` (depth from the contract when unknown)."""
    from wildfire_ros.runtime import BACKEND, DurabilityPolicy, ReliabilityPolicy

    spec = spec_for(topic)
    fallback_depth = spec.qos.depth if spec else 10
    profiles: list[QosSummary] = []
    if BACKEND == "dds":
        for endpoint in node.context.graph().endpoints(topic):
            if endpoint.kind != "publication":
                continue
            history = endpoint.qos.get("history", "")
            depth = fallback_depth
            if history.startswith("KEEP_LAST ("):
                depth = int(history[len("KEEP_LAST (") : -1]) or fallback_depth
            profiles.append(
                QosSummary(
                    endpoint.qos.get("reliability") != "BEST_EFFORT",
                    endpoint.qos.get("durability") == "TRANSIENT_LOCAL",
                    depth,
                )
            )
        return profiles
    for info in node.get_publishers_info_by_topic(topic):
        qos = info.qos_profile
        profiles.append(
            QosSummary(
                qos.reliability != ReliabilityPolicy.BEST_EFFORT,
                qos.durability == DurabilityPolicy.TRANSIENT_LOCAL,
                # Discovery does not carry the history: Fast DDS reports depth 0.
                int(qos.depth) or fallback_depth,
            )
        )
    return profiles


class BagRecorder:
    """Records topics of the running system through one node of the active backend.

    ``topics=None`` records every topic but ``exclude`` (default :data:`BULKY_TOPICS`),
    discovered every ``discovery_period`` seconds, so topics that appear later are recorded
    too. Subscriptions are raw (no deserialization). With ``use_sim_time`` the log times are
    the latest ``/clock`` (zero before it). Spin ``recorder.node`` (``rclpy.spin`` or an
    executor) and call ``close()`` at the end.
    """

    def __init__(
        self,
        output: str | Path,
        topics: Iterable[str] | None = None,
        *,
        node_name: str = "wildfire_bag_recorder",
        discovery_period: float = 0.5,
        exclude: Iterable[str] = BULKY_TOPICS,
        compression: str = DEFAULT_PRESET,
        use_sim_time: bool = False,
        chunk_period_s: float = 1.0,
        custom_data: dict[str, str] | None = None,
    ) -> None:
        from wildfire_ros.runtime import Node, get_message, qos_profile

        self.writer = BagWriter(
            output,
            compression=compression,
            chunk_period_s=chunk_period_s,
            custom_data={
                TIME_SOURCE_KEY: "sim" if use_sim_time else "system",
                **(custom_data or {}),
            },
        )
        self.node = Node(node_name)
        self._wanted = None if topics is None else set(topics)
        self._excluded = set() if topics is not None else set(exclude)
        self._subscriptions: dict[str, Any] = {}
        self._sim_time_ns: int | None = 0 if use_sim_time else None
        if use_sim_time:
            # Our own /clock subscription: the clock runs whether or not /clock is recorded.
            self._subscriptions[contract.CLOCK.name] = self.node.create_subscription(
                get_message(contract.CLOCK.type),
                contract.CLOCK.name,
                self._clock_callback,
                qos_profile(contract.CLOCK.qos),
                raw=True,
            )
        self.node.create_timer(discovery_period, self.discover_topics)
        self.discover_topics()

    @property
    def message_count(self) -> int:
        """Messages written so far."""
        return self.writer.message_count

    def _wants(self, topic: str) -> bool:
        if self._wanted is not None:
            return topic in self._wanted
        return topic not in self._excluded

    def now_ns(self) -> int:
        """Log time of a message received now."""
        return time.time_ns() if self._sim_time_ns is None else self._sim_time_ns

    def discover_topics(self) -> None:
        """Subscribe to wanted topics that have appeared in the graph; flush old chunks."""
        self.writer.flush_if_due()
        for topic, types in self.node.get_topic_names_and_types():
            if topic in self._subscriptions or not types or not self._wants(topic):
                continue
            self._subscribe(topic, types[0])

    def _add_topic(self, topic: str, type_name: str) -> None:
        profiles = offered_qos(self.node, topic)
        if not profiles:
            spec = spec_for(topic)
            qos = spec.qos if spec else contract.STREAM
            profiles = [QosSummary(qos.reliable, qos.transient_local, qos.depth)]
        self.writer.add_topic(topic, type_name, offered_qos=profiles)

    def _clock_callback(self, data: bytes) -> None:
        clock = typestore().deserialize_cdr(bytes(data), contract.CLOCK.type).clock
        stamp = int(clock.sec) * 1_000_000_000 + int(clock.nanosec)
        self._sim_time_ns = max(self._sim_time_ns or 0, stamp)
        topic = contract.CLOCK.name
        if self._wants(topic):
            if not self.writer.has_topic(topic):
                self._add_topic(topic, contract.CLOCK.type)
            self.writer.write(topic, self.now_ns(), data)

    def _subscribe(self, topic: str, type_name: str) -> None:
        from wildfire_ros.graph import adapted_qos
        from wildfire_ros.runtime import get_message

        try:
            msg_type = get_message(type_name)
        except UnknownMessageTypeError:
            self.node.get_logger().warning(f"not recording {topic}: unknown type {type_name}")
            self._subscriptions[topic] = None
            return
        # Match the publishers seen (as ros2 bag record does), else the contract's QoS.
        qos = adapted_qos(self.node, topic, depth=100)
        self._add_topic(topic, type_name)

        def record(data: bytes, topic: str = topic) -> None:
            self.writer.write(topic, self.now_ns(), data)

        self._subscriptions[topic] = self.node.create_subscription(
            msg_type, topic, record, qos, raw=True
        )

    def close(self) -> None:
        """Stop recording and finalize the bag."""
        try:
            self.node.destroy_node()
        finally:
            self.writer.close()


__all__ = ["BULKY_TOPICS", "BagRecorder", "offered_qos"]
