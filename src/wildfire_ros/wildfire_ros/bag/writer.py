"""Writing bags as ROS 2 Jazzy's ``ros2 bag record -s mcap`` writes them: :class:`BagWriter`.

A bag is a directory with one ``<name>_0.mcap`` file and ``metadata.yaml`` (version 9,
``ros_distro: jazzy``, the RIHS01 ``type_description_hash`` and offered QoS profiles of every
topic). Each topic is an MCAP channel with a ``ros2msg`` schema, CDR payloads and
``offered_qos_profiles`` and ``topic_type_hash`` metadata; messages carry per-channel sequence
numbers. Chunks are compressed with a preset of :mod:`wildfire_ros.mcap_writer`
(``zstd_fast`` by default), never the whole file, so ``ros2 bag``, Foxglove, ``mcap`` and
rosbags read the bags unchanged. ``metadata.yaml`` appears only when ``close()`` finalizes the
bag; a bag without one was not finalized (``wildfire bag reindex`` recovers it).

The live recorder (:mod:`wildfire_ros.bag.recorder`) and the bag rewriters
(:mod:`wildfire_ros.bag_repair`) both write through this class.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rosbags.rosbag2.metadata import dump_qos_v9

from wildfire_msgs_py.errors import BagError, UnknownMessageTypeError
from wildfire_msgs_py.types import normalize_type_name, typestore
from wildfire_ros.bag.metadata import PRESET_KEY, QosSummary, dump_yaml, rosbags_qos, type_hash
from wildfire_ros.mcap_writer import DEFAULT_PRESET, PRESETS, McapWriter

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence


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
                "offered_qos_profiles": dump_yaml(
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
            writer.add_metadata("rosbag2", {"serialized_metadata": dump_yaml(metadata).strip()})
            writer.close()
        finally:
            self._file.close()
        text = dump_yaml({"rosbag2_bagfile_information": metadata})
        temporary = self.path / "metadata.yaml.tmp"
        temporary.write_text(text, encoding="utf-8")
        temporary.replace(self.path / "metadata.yaml")

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


__all__ = ["BagWriter"]
