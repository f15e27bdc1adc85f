"""rosbag2 recording and reading: a directory with ``metadata.yaml`` and one ``.mcap`` file.

Written with ``rosbags.rosbag2.Writer`` (storage MCAP, metadata version 9 as ROS 2 Jazzy
writes it): ``ros2msg`` schemas, CDR payloads, so ``ros2 bag info/play``, Foxglove and the
rosbags library read our bags. Timestamps are receive times (system clock), as ``ros2 bag
record`` does by default.

* :class:`BagWriter` — add topics and raw CDR messages; ``close()`` finalizes the file.
* :class:`BagRecorder` — a node that subscribes (raw) to given topics or to every topic,
  including topics that appear later, and writes each message; finalize with ``close()``.
* :func:`read_messages` — typed messages in time order (rosbags dataclasses with numpy arrays;
  the codecs of :mod:`wildfire_msgs_py.codecs` accept them) for offline training.
* :func:`bag_info` — what ``ros2 bag info`` prints.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Reader, ReaderError, StoragePlugin, Writer, WriterError

from wildfire_msgs_py.contract import spec_for
from wildfire_msgs_py.dds.types import normalize_type_name, typestore
from wildfire_msgs_py.errors import BagError, UnknownMessageTypeError

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator

_ZERO = QosTime(0, 0)
_INFINITE = QosTime(0x7FFFFFFF, 0xFFFFFFFF)


class BagMessage(NamedTuple):
    """One recorded message."""

    topic: str
    type: str
    """ROS type name, ``pkg/msg/Type``."""
    time_ns: int
    """Receive time in nanoseconds since the epoch."""
    message: Any
    """Deserialized message (rosbags dataclass), or CDR bytes when read with ``raw=True``."""


@dataclass(frozen=True)
class TopicSummary:
    """One topic of a bag."""

    name: str
    type: str
    message_count: int


@dataclass(frozen=True)
class BagInfo:
    """Summary of a bag (``ros2 bag info``)."""

    path: Path
    storage: str
    size_bytes: int
    start_ns: int
    end_ns: int
    message_count: int
    topics: tuple[TopicSummary, ...]

    @property
    def duration_s(self) -> float:
        """Time from first to last message."""
        return max(0, self.end_ns - self.start_ns) / 1e9


def _rosbags_qos(reliable: bool, transient_local: bool, depth: int) -> Qos:
    return Qos(
        QosHistory.KEEP_LAST,
        depth,
        QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
        QosDurability.TRANSIENT_LOCAL if transient_local else QosDurability.VOLATILE,
        _INFINITE,
        _INFINITE,
        QosLiveliness.AUTOMATIC,
        _INFINITE,
        False,
    )


class BagWriter:
    """Writes raw CDR messages into a new rosbag2 MCAP directory."""

    def __init__(self, output: str | Path) -> None:
        self.path = Path(output)
        if self.path.exists():
            raise BagError(f"bag output {self.path}: already exists, expected a new directory")
        if not self.path.parent.is_dir():
            raise BagError(f"bag output {self.path}: parent directory does not exist")
        try:
            self._writer: Writer | None = Writer(
                self.path, version=9, storage_plugin=StoragePlugin.MCAP
            )
            self._writer.open()
        except (WriterError, OSError) as error:
            raise BagError(f"bag output {self.path}: cannot create ({error})") from None
        self._connections: dict[str, Any] = {}
        self.message_count = 0

    def has_topic(self, topic: str) -> bool:
        """True once ``add_topic`` was called for ``topic``."""
        return topic in self._connections

    def add_topic(
        self,
        topic: str,
        type_name: str,
        *,
        reliable: bool = True,
        transient_local: bool = False,
        depth: int = 10,
    ) -> None:
        """Declare a topic (its schema is the ROS 2 Jazzy definition of ``type_name``)."""
        if self._writer is None:
            raise BagError(f"bag {self.path}: already closed")
        name = normalize_type_name(type_name)
        if name not in typestore().fielddefs:
            raise UnknownMessageTypeError(f"message type {type_name!r} is not a ROS 2 Jazzy type")
        self._connections[topic] = self._writer.add_connection(
            topic,
            name,
            typestore=typestore(),
            offered_qos_profiles=[_rosbags_qos(reliable, transient_local, depth)],
        )

    def write(self, topic: str, time_ns: int, cdr: bytes | memoryview) -> None:
        """Append one serialized message."""
        if self._writer is None:
            raise BagError(f"bag {self.path}: already closed")
        self._writer.write(self._connections[topic], int(time_ns), bytes(cdr))
        self.message_count += 1

    def close(self) -> None:
        """Write the MCAP summary and ``metadata.yaml``; safe to call twice."""
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.close()

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


class BagRecorder:
    """Records topics of the running system through one node of the active backend.

    ``topics=None`` records every topic, discovered every ``discovery_period`` seconds, so
    topics that appear later are recorded too. Subscriptions are raw (no deserialization).
    Spin ``recorder.node`` (``rclpy.spin`` or an executor) and call ``close()`` at the end.
    """

    def __init__(
        self,
        output: str | Path,
        topics: Iterable[str] | None = None,
        *,
        node_name: str = "wildfire_bag_recorder",
        discovery_period: float = 0.5,
    ) -> None:
        from wildfire_msgs_py.runtime import Node

        self.writer = BagWriter(output)
        self.node = Node(node_name)
        self._wanted = None if topics is None else set(topics)
        self._subscriptions: dict[str, Any] = {}
        self.node.create_timer(discovery_period, self.discover_topics)
        self.discover_topics()

    @property
    def message_count(self) -> int:
        """Messages written so far."""
        return self.writer.message_count

    def discover_topics(self) -> None:
        """Subscribe to wanted topics that have appeared in the graph."""
        for topic, types in self.node.get_topic_names_and_types():
            if topic in self._subscriptions or not types:
                continue
            if self._wanted is not None and topic not in self._wanted:
                continue
            self._subscribe(topic, types[0])

    def _subscribe(self, topic: str, type_name: str) -> None:
        from wildfire_msgs_py.graph import adapted_qos
        from wildfire_msgs_py.runtime import DurabilityPolicy, ReliabilityPolicy, get_message

        try:
            msg_type = get_message(type_name)
        except UnknownMessageTypeError:
            self.node.get_logger().warning(f"not recording {topic}: unknown type {type_name}")
            self._subscriptions[topic] = None
            return
        # Match the publishers seen (as ros2 bag record does), else the contract's QoS.
        qos = adapted_qos(self.node, topic, depth=100)
        reliable = qos.reliability == ReliabilityPolicy.RELIABLE
        latched = qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
        spec = spec_for(topic)
        self.writer.add_topic(
            topic,
            type_name,
            reliable=reliable,
            transient_local=latched,
            depth=spec.qos.depth if spec else 10,
        )

        def record(data: bytes, topic: str = topic) -> None:
            self.writer.write(topic, time.time_ns(), data)

        self._subscriptions[topic] = self.node.create_subscription(
            msg_type, topic, record, qos, raw=True
        )

    def close(self) -> None:
        """Stop recording and finalize the bag."""
        try:
            self.node.destroy_node()
        finally:
            self.writer.close()


def _open_reader(bag_dir: str | Path) -> Reader:
    path = Path(bag_dir)
    if not path.exists():
        raise BagError(f"bag {path}: no such directory")
    if not (path / "metadata.yaml").is_file():
        raise BagError(f"bag {path}: expected a rosbag2 directory with metadata.yaml")
    try:
        reader = Reader(path)
        reader.open()
    except (ReaderError, OSError, KeyError, ValueError) as error:
        raise BagError(f"bag {path}: unreadable or corrupt ({error})") from None
    return reader


def read_messages(
    bag_dir: str | Path, topics: Iterable[str] | None = None, *, raw: bool = False
) -> Iterator[BagMessage]:
    """Messages of a bag in time order, deserialized with the ROS 2 Jazzy type store."""
    reader = _open_reader(bag_dir)
    store = typestore()
    wanted = None if topics is None else set(topics)
    try:
        connections = [c for c in reader.connections if wanted is None or c.topic in wanted]
        if wanted is not None:
            missing = wanted - {c.topic for c in connections}
            if missing:
                raise BagError(f"bag {bag_dir}: no topic {', '.join(sorted(missing))}")
        try:
            for connection, time_ns, data in reader.messages(connections=connections):
                message = data if raw else store.deserialize_cdr(data, connection.msgtype)
                yield BagMessage(connection.topic, connection.msgtype, time_ns, message)
        except (ReaderError, ValueError, IndexError, KeyError) as error:
            raise BagError(f"bag {bag_dir}: corrupt message data ({error})") from None
    finally:
        reader.close()


def bag_info(bag_dir: str | Path) -> BagInfo:
    """Summary of a bag; raises :class:`BagError` when missing or corrupt."""
    reader = _open_reader(bag_dir)
    try:
        counts: dict[str, int] = {}
        for connection in reader.connections:
            counts[connection.topic] = counts.get(connection.topic, 0) + connection.msgcount
        topics = tuple(
            TopicSummary(c.topic, c.msgtype, counts[c.topic])
            for c in sorted(reader.connections, key=lambda c: c.topic)
        )
        path = Path(bag_dir)
        size = sum(f.stat().st_size for f in path.iterdir() if f.is_file())
        count = reader.message_count
        return BagInfo(
            path=path,
            storage="mcap",
            size_bytes=size,
            start_ns=reader.start_time if count else 0,
            end_ns=reader.end_time - 1 if count else 0,  # rosbags: end is exclusive
            message_count=count,
            topics=topics,
        )
    finally:
        reader.close()


__all__ = [
    "BagInfo",
    "BagMessage",
    "BagRecorder",
    "BagWriter",
    "TopicSummary",
    "bag_info",
    "read_messages",
]
