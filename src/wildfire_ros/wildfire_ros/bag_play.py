"""Put a recorded bag back on the wire, as ``ros2 bag play`` does (not on pip).

Every message is published on its topic with the QoS its publishers offered when it was
recorded (transient-local maps stay latched for late subscribers), paced by the recorded log
times divided by ``rate``. A lockstep bag (log times on sim time) therefore plays at the pace
it was simulated, and its recorded ``/clock`` is played with it, so ``use_sim_time`` nodes
follow the recorded sim time. The payloads are the recorded CDR bytes: rclpy publishes them
as they are; the DDS backend, which publishes message objects only, deserializes them first
(our serializer writes the same bytes, tested against rosbags').
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from wildfire_msgs_py.contract import spec_for
from wildfire_msgs_py.errors import BagError
from wildfire_ros.bag import (
    QosSummary,
    bag_info,
    open_reader,
    qos_summary,
    read_messages,
)

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable


#: Smallest history of a played volatile topic (see :func:`playback_qos`).
VOLATILE_MIN_DEPTH = 100


@dataclass(frozen=True)
class PlayTopic:
    """One topic to play."""

    name: str
    type: str
    qos: QosSummary
    message_count: int


def playback_qos(offered: Iterable[QosSummary], topic: str) -> QosSummary:
    """One publisher QoS from the recorded offers (rosbag2's rule: the weakest common one).

    Reliable and transient-local only when every recorded publisher offered it, the deepest
    history offered; without recorded QoS, the contract's, else reliable/volatile/10. Volatile
    topics get at least :data:`VOLATILE_MIN_DEPTH`: a reliable writer with a history of 1
    (``/clock``) drops unacknowledged samples when played faster than a subscriber takes
    them, and depth does not change matching. Latched topics keep their depth, so a late
    subscriber still gets the latest map only.
    """
    profiles = list(offered)
    if not profiles:
        spec = spec_for(topic)
        if spec is None:
            return QosSummary(True, False, 10)
        return QosSummary(spec.qos.reliable, spec.qos.transient_local, spec.qos.depth)
    latched = all(p.transient_local for p in profiles)
    depth = max(p.depth for p in profiles)
    return QosSummary(
        all(p.reliable for p in profiles),
        latched,
        max(depth, 1) if latched else max(depth, VOLATILE_MIN_DEPTH),
    )


def bag_topics(bag_dir: str | Path, topics: Iterable[str] | None = None) -> list[PlayTopic]:
    """The topics of a bag to play, with their playback QoS."""
    reader = open_reader(bag_dir)
    try:
        found: dict[str, PlayTopic] = {}
        for c in reader.connections:
            offered = [qos_summary(q) for q in getattr(c.ext, "offered_qos_profiles", ())]
            found[c.topic] = PlayTopic(
                c.topic, c.msgtype, playback_qos(offered, c.topic), c.msgcount
            )
    finally:
        reader.close()
    if topics is None:
        return sorted(found.values(), key=lambda t: t.name)
    wanted = list(dict.fromkeys(topics))
    missing = [t for t in wanted if t not in found]
    if missing:
        raise BagError(
            f"bag {bag_dir}: no topic {', '.join(missing)} (it has {', '.join(sorted(found))})"
        )
    return [found[t] for t in wanted]


@dataclass
class PlayStats:
    """What a playback did."""

    published: int = 0
    loops: int = 0
    interrupted: bool = False


class BagPlayer:
    """Plays a bag through one node of the active backend (``rclpy.init()`` first).

    ``start_offset_s`` skips that much of the bag's beginning; ``loop`` plays it again and
    again (until Ctrl-C); ``delay_s`` waits after creating the publishers so subscribers
    (``bag record``, ``topic echo``) can discover them first.
    """

    def __init__(
        self,
        bag_dir: str | Path,
        *,
        topics: Iterable[str] | None = None,
        rate: float = 1.0,
        start_offset_s: float = 0.0,
        loop: bool = False,
        node_name: str = "wildfire_bag_player",
    ) -> None:
        from wildfire_ros.runtime import Node

        if rate <= 0:
            raise BagError(f"--rate {rate}: expected a rate > 0")
        if start_offset_s < 0:
            raise BagError(f"--start-offset {start_offset_s}: expected seconds >= 0")
        self.bag = Path(bag_dir)
        self.topics = bag_topics(self.bag, topics)
        # Offsets and pacing count from the start of the bag, whichever topics are played.
        self.start_ns = bag_info(self.bag, sizes=False).start_ns
        self.rate = rate
        self.start_offset_ns = int(start_offset_s * 1e9)
        self.loop = loop
        self.node = Node(node_name)
        self._publishers: dict[str, Any] = {}
        self._types: dict[str, Any] = {}
        self._create_publishers()
        self.stats = PlayStats()

    @property
    def message_count(self) -> int:
        """Messages one pass publishes (before the start offset is applied)."""
        return sum(t.message_count for t in self.topics)

    def _create_publishers(self) -> None:
        from wildfire_ros.runtime import (
            DurabilityPolicy,
            HistoryPolicy,
            QoSProfile,
            ReliabilityPolicy,
            get_message,
        )

        for topic in self.topics:
            qos = QoSProfile(
                history=HistoryPolicy.KEEP_LAST,
                depth=topic.qos.depth,
                reliability=(
                    ReliabilityPolicy.RELIABLE
                    if topic.qos.reliable
                    else ReliabilityPolicy.BEST_EFFORT
                ),
                durability=(
                    DurabilityPolicy.TRANSIENT_LOCAL
                    if topic.qos.transient_local
                    else DurabilityPolicy.VOLATILE
                ),
            )
            self._types[topic.name] = get_message(topic.type)
            self._publishers[topic.name] = self.node.create_publisher(
                self._types[topic.name], topic.name, qos
            )

    def subscription_counts(self) -> dict[str, int]:
        """Matched subscriptions of every played topic."""
        return {name: p.get_subscription_count() for name, p in self._publishers.items()}

    def _publish(self, topic: str, data: bytes) -> None:
        from wildfire_ros.runtime import BACKEND, deserialize_message

        publisher = self._publishers[topic]
        if BACKEND == "rclpy":
            publisher.publish(data)  # rclpy publishes serialized bytes as they are
        else:
            publisher.publish(deserialize_message(data, self._types[topic]))

    def _wait_until(self, deadline: float) -> None:
        """Sleep until the monotonic ``deadline``, serving the node's events meanwhile."""
        from wildfire_ros.runtime import rclpy

        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return
            rclpy.spin_once(self.node, timeout_sec=min(left, 0.05))

    def wait(self, seconds: float) -> None:
        """Spin the node for ``seconds`` (discovery)."""
        self._wait_until(time.monotonic() + seconds)

    def wait_for_subscribers(self, timeout_s: float | None = None) -> bool:
        """Spin until every played topic has a matched subscription (False on timeout).

        Volatile topics reach only subscribers matched when a message is sent: a recorder
        started next to the player must first discover the player's topics.
        """
        end = None if timeout_s is None else time.monotonic() + timeout_s
        while min(self.subscription_counts().values(), default=1) < 1:
            if end is not None and time.monotonic() >= end:
                return False
            self.wait(0.1)
        return True

    def play(self, progress: Callable[[int], None] | None = None) -> PlayStats:
        """Play once (or in a loop); Ctrl-C ends it cleanly, the stats say so."""
        names = [t.name for t in self.topics]
        try:
            while True:
                start_wall = time.monotonic()
                played = self.stats.published
                for record in read_messages(self.bag, names, raw=True):
                    offset = record.time_ns - self.start_ns
                    if offset < self.start_offset_ns:
                        continue
                    due = start_wall + (offset - self.start_offset_ns) / 1e9 / self.rate
                    self._wait_until(due)
                    self._publish(record.topic, bytes(record.message))
                    self.stats.published += 1
                    if progress is not None:
                        progress(self.stats.published)
                self.stats.loops += 1
                if not self.loop or self.stats.published == played:
                    break
        except KeyboardInterrupt:
            self.stats.interrupted = True
        return self.stats

    def close(self, linger_s: float = 0.5) -> None:
        """Let reliable messages reach their subscribers, then destroy the node."""
        from wildfire_ros.runtime import BACKEND, Duration

        try:
            if BACKEND == "rclpy":
                for publisher in self._publishers.values():
                    publisher.wait_for_all_acked(Duration(seconds=2))
            self.wait(linger_s)
        except KeyboardInterrupt:
            pass
        finally:
            self.node.destroy_node()


__all__ = [
    "VOLATILE_MIN_DEPTH",
    "BagPlayer",
    "PlayStats",
    "PlayTopic",
    "bag_topics",
    "playback_qos",
]
