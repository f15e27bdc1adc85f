"""Summaries of bags, as ``ros2 bag info`` prints them: :func:`bag_info`.

Besides what ``ros2 bag info`` shows (duration, message counts, the type of every topic),
:class:`BagInfo` carries each topic's payload bytes, type hash and offered QoS, the chunk
compression and its ratio (from the MCAP chunk indexes), and what we record in
``custom_data``: the compression preset and the time source of the log times.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from rosbags.rosbag2 import ReaderError

from wildfire_msgs_py.errors import BagError
from wildfire_ros.bag.metadata import (
    PRESET_KEY,
    TIME_SOURCE_KEY,
    QosSummary,
    qos_summary,
    read_custom_data,
)
from wildfire_ros.bag.reader import mcap_files, open_reader

if TYPE_CHECKING:
    from collections.abc import Sequence


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
        files = mcap_files(path)
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


__all__ = ["BagInfo", "TopicSummary", "bag_info"]
