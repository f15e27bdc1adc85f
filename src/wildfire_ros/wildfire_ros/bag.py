"""rosbag2 recording and reading: a directory with ``metadata.yaml`` and one ``.mcap`` file.

Bags are written as ROS 2 Jazzy's ``ros2 bag record -s mcap`` writes them: ``metadata.yaml``
version 9 with ``ros_distro: jazzy``, the RIHS01 ``type_description_hash`` of every topic
(computed from the type description as Jazzy does, by the rosbags type store) and the offered
QoS profiles of its publishers; MCAP channels with ``offered_qos_profiles`` and
``topic_type_hash`` metadata, ``ros2msg`` schemas, CDR payloads and per-channel sequence
numbers. Chunks are zstd-compressed (:mod:`wildfire_ros.mcap_writer`, preset
``zstd_fast``), so ``ros2 bag``, Foxglove, ``mcap`` and rosbags read them unchanged.

Log times are receive times on the system clock, as ``ros2 bag record`` does by default, or
on sim time (``use_sim_time``, as ``ros2 bag record --use-sim-time``): the latest ``/clock``
received, zero before the first one. ``wildfire run`` records its lockstep runs so, which lets
``wildfire bag play`` replay them at the pace they were simulated.

* :class:`BagWriter` — add topics and raw CDR messages; ``close()`` finalizes the file.
* :class:`BagRecorder` — a node that subscribes (raw) to given topics or to every topic,
  including topics that appear later, and writes each message; finalize with ``close()``.
  Recording every topic leaves out :data:`BULKY_TOPICS` unless asked for.
* :func:`read_messages` — typed messages in time order (rosbags dataclasses with numpy arrays;
  the codecs of :mod:`wildfire_msgs_py.codecs` accept them) for offline training.
* :func:`bag_info` — what ``ros2 bag info`` prints, with compression and per-topic sizes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from io import StringIO
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
from rosbags.rosbag2 import Reader, ReaderError
from rosbags.rosbag2.metadata import dump_qos_v9
from ruamel.yaml import YAML

from wildfire_msgs_py import contract
from wildfire_msgs_py.contract import spec_for
from wildfire_msgs_py.errors import BagError, UnknownMessageTypeError
from wildfire_msgs_py.types import normalize_type_name, typestore
from wildfire_ros.mcap_writer import DEFAULT_PRESET, PRESETS, McapWriter

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator, Mapping, Sequence

_INFINITE = QosTime(0x7FFFFFFF, 0xFFFFFFFF)

#: Topics that recording *every* topic leaves out (``bag record -a``, ``wildfire run
#: --record``) unless asked for: 93 % of a belief run's bytes, and nothing needs them offline.
#: The exact ages are rebuilt from the visits (:mod:`wildfire_learning.bag_transitions`), the
#: snapshots exist only for a restarted aggregator. Name them to record them.
BULKY_TOPICS: tuple[str, ...] = (contract.BELIEF_AGE_EXACT.name, contract.BELIEF_SNAPSHOT.name)

#: Keys of ``custom_data`` in ``metadata.yaml`` (rosbag2's free-form map).
PRESET_KEY = "wildfire.compression_preset"
TIME_SOURCE_KEY = "wildfire.time_source"


class BagMessage(NamedTuple):
    """One recorded message."""

    topic: str
    type: str
    """ROS type name, ``pkg/msg/Type``."""
    time_ns: int
    """Log time in nanoseconds: receive time (system clock or sim time)."""
    message: Any
    """Deserialized message (rosbags dataclass), or CDR bytes when read with ``raw=True``."""


@dataclass(frozen=True)
class QosSummary:
    """The QoS policies of an offered profile that matter for matching and replay."""

    reliable: bool
    transient_local: bool
    depth: int


@dataclass(frozen=True)
class TopicSummary:
    """One topic of a bag."""

    name: str
    type: str
    message_count: int
    size_bytes: int = 0
    """Serialized payload bytes (uncompressed) of every message of the topic."""
    type_hash: str = ""
    """RIHS01 type description hash, empty when the bag has none."""
    offered_qos: tuple[QosSummary, ...] = ()


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
    compression: str = ""
    """Chunk compression (``zstd``) or empty."""
    preset: str = ""
    """Compression preset the bag was written with, when recorded."""
    chunk_bytes: int = 0
    """Stored (compressed) bytes of every chunk."""
    uncompressed_chunk_bytes: int = 0
    ros_distro: str = ""
    time_source: str = ""
    """``sim`` (log times on /clock), ``system``, or empty when not recorded."""

    @property
    def duration_s(self) -> float:
        """Time from first to last message."""
        return max(0, self.end_ns - self.start_ns) / 1e9

    @property
    def compression_ratio(self) -> float:
        """Uncompressed over stored chunk bytes (1 without compression)."""
        return self.uncompressed_chunk_bytes / self.chunk_bytes if self.chunk_bytes else 1.0


def rosbags_qos(profile: QosSummary) -> Qos:
    """A rosbags QoS profile (for ``metadata.yaml``) of a summary."""
    return Qos(
        QosHistory.KEEP_LAST,
        profile.depth,
        QosReliability.RELIABLE if profile.reliable else QosReliability.BEST_EFFORT,
        QosDurability.TRANSIENT_LOCAL if profile.transient_local else QosDurability.VOLATILE,
        _INFINITE,
        _INFINITE,
        QosLiveliness.AUTOMATIC,
        _INFINITE,
        False,
    )


def qos_summary(profile: Qos) -> QosSummary:
    """The summary of a rosbags QoS profile read from a bag."""
    return QosSummary(
        reliable=profile.reliability != QosReliability.BEST_EFFORT,
        transient_local=profile.durability == QosDurability.TRANSIENT_LOCAL,
        depth=int(profile.depth),
    )


def _yaml() -> YAML:
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    return yaml


def _dump_yaml(data: Any) -> str:
    stream = StringIO()
    _yaml().dump(data, stream)
    return stream.getvalue()


def parse_offered_qos(text: str) -> list[QosSummary]:
    """Offered QoS profiles of an MCAP channel's ``offered_qos_profiles`` (YAML) metadata."""
    try:
        profiles = _yaml().load(text) or []
        return [
            QosSummary(
                reliable=str(p.get("reliability", "reliable")).lower() != "best_effort",
                transient_local=str(p.get("durability", "volatile")).lower() == "transient_local",
                depth=int(p.get("depth", 0) or 0),
            )
            for p in profiles
            if isinstance(p, dict)
        ]
    except Exception:  # foreign metadata: a bag without QoS rather than no bag
        return []


def type_hash(type_name: str) -> str:
    """RIHS01 hash of a Jazzy type (as ``ros2 topic info -v`` shows it), or empty."""
    try:
        return typestore().hash_rihs01(normalize_type_name(type_name))
    except Exception:  # a type the store cannot describe: rosbag2 writes "" too
        return ""


@dataclass
class _Topic:
    name: str
    type: str
    channel_id: int
    qos: list[QosSummary]
    type_hash: str
    count: int = 0


class BagWriter:
    """Writes raw CDR messages into a new rosbag2 MCAP directory.

    ``compression`` is a preset of :data:`wildfire_ros.mcap_writer.PRESETS`;
    ``chunk_period_s`` also closes a chunk that many seconds after its first message, so a
    killed recorder loses at most that much (see ``wildfire bag reindex``).
    """

    def __init__(
        self,
        output: str | Path,
        *,
        compression: str = DEFAULT_PRESET,
        chunk_period_s: float | None = None,
        custom_data: Mapping[str, str] | None = None,
    ) -> None:
        self.path = Path(output)
        if compression not in PRESETS:
            raise BagError(f"compression {compression!r}: expected one of {', '.join(PRESETS)}")
        if self.path.exists():
            raise BagError(f"bag output {self.path}: already exists, expected a new directory")
        if not self.path.parent.is_dir():
            raise BagError(f"bag output {self.path}: parent directory does not exist")
        self.mcap_path = self.path / f"{self.path.name}_0.mcap"
        try:
            self.path.mkdir()
            self._file = self.mcap_path.open("xb")
        except OSError as error:
            raise BagError(f"bag output {self.path}: cannot create ({error})") from None
        self.preset = PRESETS[compression]
        self._mcap: McapWriter | None = McapWriter(
            self._file, self.preset, library="wildfire_msgs_py", chunk_period_s=chunk_period_s
        )
        self.custom_data = {PRESET_KEY: self.preset.name, **(custom_data or {})}
        # Also at the start of the file, where a repair finds it when the recorder was killed.
        self._mcap.add_metadata("wildfire", self.custom_data)
        self._schemas: dict[str, int] = {}
        self._topics: dict[str, _Topic] = {}
        self._start_ns: int | None = None
        self._end_ns = 0
        self.message_count = 0

    def has_topic(self, topic: str) -> bool:
        """True once ``add_topic`` was called for ``topic``."""
        return topic in self._topics

    def _writer(self) -> McapWriter:
        if self._mcap is None:
            raise BagError(f"bag {self.path}: already closed")
        return self._mcap

    def add_topic(
        self,
        topic: str,
        type_name: str,
        *,
        reliable: bool = True,
        transient_local: bool = False,
        depth: int = 10,
        offered_qos: Sequence[QosSummary] | None = None,
        schema: tuple[str, bytes] | None = None,
        hash_rihs01: str | None = None,
    ) -> None:
        """Declare a topic.

        Its schema is the ROS 2 Jazzy definition of ``type_name`` unless ``schema`` (encoding,
        text) is given, as when copying a bag; ``offered_qos`` lists one profile per publisher
        (default: one profile from ``reliable``, ``transient_local`` and ``depth``).
        """
        writer = self._writer()
        name = normalize_type_name(type_name)
        if schema is None:
            if name not in typestore().fielddefs:
                raise UnknownMessageTypeError(
                    f"message type {type_name!r} is not a ROS 2 Jazzy type"
                )
            msgdef, _ = typestore().generate_msgdef(name, ros_version=2)
            schema = ("ros2msg", msgdef.encode())
        if name not in self._schemas:
            self._schemas[name] = writer.add_schema(name, schema[0], schema[1])
        profiles = list(offered_qos or [QosSummary(reliable, transient_local, depth)])
        digest = type_hash(name) if hash_rihs01 is None else hash_rihs01
        channel_id = writer.add_channel(
            topic,
            self._schemas[name],
            "cdr",
            {
                "offered_qos_profiles": _dump_yaml(
                    dump_qos_v9([rosbags_qos(p) for p in profiles])
                ).strip(),
                "topic_type_hash": digest,
            },
        )
        self._topics[topic] = _Topic(topic, name, channel_id, profiles, digest)

    def write(
        self,
        topic: str,
        time_ns: int,
        cdr: bytes | memoryview,
        *,
        publish_time_ns: int | None = None,
        sequence: int | None = None,
    ) -> None:
        """Append one serialized message (sequence numbers count per topic unless given)."""
        writer = self._writer()
        entry = self._topics[topic]
        time_ns = int(time_ns)
        writer.write(
            entry.channel_id,
            time_ns,
            bytes(cdr),
            publish_time_ns=publish_time_ns,
            sequence=sequence,
        )
        entry.count += 1
        self.message_count += 1
        self._start_ns = time_ns if self._start_ns is None else min(self._start_ns, time_ns)
        self._end_ns = max(self._end_ns, time_ns)

    def flush_if_due(self) -> None:
        """Close the open chunk when it is older than the chunk period."""
        if self._mcap is not None:
            self._mcap.flush_if_due()

    def metadata(self) -> dict[str, Any]:
        """The ``rosbag2_bagfile_information`` of ``metadata.yaml`` (version 9, Jazzy)."""
        start = self._start_ns or 0
        duration = max(0, self._end_ns - start)
        return {
            "version": 9,
            "storage_identifier": "mcap",
            "relative_file_paths": [self.mcap_path.name],
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": self.message_count,
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": t.name,
                        "type": t.type,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": dump_qos_v9([rosbags_qos(p) for p in t.qos]),
                        "type_description_hash": t.type_hash,
                    },
                    "message_count": t.count,
                }
                for t in self._topics.values()
            ],
            # Chunk compression is the storage's business: rosbag2 leaves these empty.
            "compression_format": "",
            "compression_mode": "",
            "files": [
                {
                    "path": self.mcap_path.name,
                    "starting_time": {"nanoseconds_since_epoch": start},
                    "duration": {"nanoseconds": duration},
                    "message_count": self.message_count,
                }
            ],
            "custom_data": dict(self.custom_data),
            "ros_distro": "jazzy",
        }

    def close(self) -> None:
        """Write the MCAP summary and ``metadata.yaml``; safe to call twice."""
        writer, self._mcap = self._mcap, None
        if writer is None:
            return
        metadata = self.metadata()
        try:
            writer.add_metadata("rosbag2", {"serialized_metadata": _dump_yaml(metadata).strip()})
            writer.close()
        finally:
            self._file.close()
        text = _dump_yaml({"rosbag2_bagfile_information": metadata})
        temporary = self.path / "metadata.yaml.tmp"
        temporary.write_text(text, encoding="utf-8")
        temporary.replace(self.path / "metadata.yaml")

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


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
    ) -> None:
        from wildfire_ros.runtime import Node, get_message, qos_profile

        self.writer = BagWriter(
            output,
            compression=compression,
            chunk_period_s=chunk_period_s,
            custom_data={TIME_SOURCE_KEY: "sim" if use_sim_time else "system"},
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


def _mcap_files(path: Path) -> list[Path]:
    return sorted(path.glob("*.mcap"))


def open_reader(bag_dir: str | Path) -> Reader:
    """An open rosbags reader; :class:`BagError` names the file and what is wrong."""
    path = Path(bag_dir)
    if not path.exists():
        raise BagError(f"bag {path}: no such directory")
    if path.is_file():
        raise BagError(f"bag {path}: expected a rosbag2 directory, got a file")
    if not (path / "metadata.yaml").is_file():
        files = _mcap_files(path)
        if files:
            raise BagError(
                f"bag {path}: no metadata.yaml next to {files[0].name} (recording not "
                f"finalized?); `wildfire bag reindex {path}` recovers it"
            )
        raise BagError(f"bag {path}: expected a rosbag2 directory with metadata.yaml")
    try:
        reader = Reader(path)
    except (ReaderError, OSError, KeyError, ValueError, TypeError) as error:
        raise BagError(f"bag {path / 'metadata.yaml'}: unreadable or corrupt ({error})") from None
    try:
        reader.open()
    except (ReaderError, OSError, KeyError, ValueError, TypeError, IndexError) as error:
        names = ", ".join(p.name for p in _mcap_files(path)) or "its .mcap file"
        raise BagError(
            f"bag {path}: {names} is truncated or corrupt ({error}); "
            f"`wildfire bag reindex {path}` recovers its complete chunks"
        ) from None
    return reader


def read_messages(
    bag_dir: str | Path, topics: Iterable[str] | None = None, *, raw: bool = False
) -> Iterator[BagMessage]:
    """Messages of a bag in time order, deserialized with the ROS 2 Jazzy type store."""
    reader = open_reader(bag_dir)
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
        except (ReaderError, ValueError, IndexError, KeyError, OSError) as error:
            raise BagError(f"bag {bag_dir}: corrupt message data ({error})") from None
    finally:
        reader.close()


def _chunk_totals(files: Sequence[Path]) -> tuple[str, int, int]:
    """(compression, stored bytes, uncompressed bytes) over the chunks of MCAP files."""
    from mcap.reader import make_reader

    kinds: set[str] = set()
    stored = raw = 0
    for file in files:
        with file.open("rb") as stream:
            summary = make_reader(stream).get_summary()
        for index in summary.chunk_indexes if summary else ():
            kinds.add(index.compression)
            stored += index.compressed_size
            raw += index.uncompressed_size
    return ",".join(sorted(k for k in kinds if k)), stored, raw


def read_custom_data(path: Path) -> dict[str, str]:
    """``custom_data`` of a bag's ``metadata.yaml`` (rosbags' reader does not expose it)."""
    information = _yaml().load((path / "metadata.yaml").read_text(encoding="utf-8"))
    custom = (information.get("rosbag2_bagfile_information") or {}).get("custom_data") or {}
    return {str(k): str(v) for k, v in custom.items()}


def bag_info(bag_dir: str | Path, *, sizes: bool = True) -> BagInfo:
    """Summary of a bag; raises :class:`BagError` when missing or corrupt.

    ``sizes`` reads every message to add up the bytes of each topic.
    """
    path = Path(bag_dir)
    reader = open_reader(path)
    try:
        counts: dict[str, int] = {}
        for connection in reader.connections:
            counts[connection.topic] = counts.get(connection.topic, 0) + connection.msgcount
        topic_bytes = dict.fromkeys(counts, 0)
        if sizes:
            try:
                for connection, _, data in reader.messages():
                    topic_bytes[connection.topic] += len(data)
            except (ReaderError, ValueError, IndexError, KeyError, OSError) as error:
                raise BagError(f"bag {path}: corrupt message data ({error})") from None
        topics = tuple(
            TopicSummary(
                c.topic,
                c.msgtype,
                counts[c.topic],
                topic_bytes[c.topic],
                c.digest if c.digest.startswith("RIHS01_") else "",
                tuple(qos_summary(q) for q in getattr(c.ext, "offered_qos_profiles", ())),
            )
            for c in sorted(reader.connections, key=lambda c: c.topic)
        )
        files = _mcap_files(path)
        compression, stored, raw = _chunk_totals(files)
        custom = read_custom_data(path)
        count = reader.message_count
        return BagInfo(
            path=path,
            storage="mcap",
            size_bytes=sum(f.stat().st_size for f in [*files, path / "metadata.yaml"]),
            start_ns=reader.start_time if count else 0,
            end_ns=reader.end_time - 1 if count else 0,  # rosbags: end is exclusive
            message_count=count,
            topics=topics,
            compression=compression,
            preset=str(custom.get(PRESET_KEY, "")),
            chunk_bytes=stored,
            uncompressed_chunk_bytes=raw,
            ros_distro=str(reader.ros_distro or ""),
            time_source=str(custom.get(TIME_SOURCE_KEY, "")),
        )
    except BagError:
        raise
    except Exception as error:  # the mcap summary of a damaged file, whatever it raises
        raise BagError(f"bag {path}: unreadable or corrupt ({error})") from None
    finally:
        reader.close()


__all__ = [
    "BULKY_TOPICS",
    "BagInfo",
    "BagMessage",
    "BagRecorder",
    "BagWriter",
    "QosSummary",
    "TopicSummary",
    "bag_info",
    "offered_qos",
    "open_reader",
    "parse_offered_qos",
    "qos_summary",
    "read_custom_data",
    "read_messages",
    "rosbags_qos",
    "type_hash",
]
