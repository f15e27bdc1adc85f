"""A small MCAP writer with chunk compression presets, for rosbag2 bags.

The ``mcap`` package's own writer compresses every chunk at one fixed zstd level and cannot
close a chunk on a timer; this one is built from that package's record classes (so the bytes
of every record are the reference implementation's) and adds what recording needs:

* **presets** (:data:`PRESETS`), named like rosbag2's MCAP storage presets: ``none``,
  ``zstd_fast`` (the default) and ``zstd_small``. Only chunks are compressed, never the whole
  file, so ``mcap``, ``rosbags``, ``ros2 bag`` and Foxglove read the bags as they are.
  rosbag2's ``zstd_fast`` asks the MCAP library for its "Fastest" level, which current zstd
  maps to ``ZSTD_minCLevel()`` and which barely compresses (a 1.0 ratio on our topics); we use
  level 1 instead, 30 times smaller for the same write time on our data.
* **chunk periods**: a chunk is also closed ``chunk_period_s`` seconds (wall clock) after its
  first message, so a recorder killed with SIGKILL loses at most that much (every closed chunk
  is complete on disk and ``wildfire bag reindex`` recovers it).
* per-channel **sequence numbers** (MCAP: "if not assigned by the publisher, recorded by the
  recorder"), chunk CRCs (always: they let a repair trust what it recovers), message and
  chunk indexes, statistics and summary offsets.

Schema and channel records are written to the data section as soon as they are added (not
inside the open chunk), so a truncated file still defines every channel of its complete chunks.
"""

from __future__ import annotations

import struct
import time
import zlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, BinaryIO

import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

if TYPE_CHECKING:
    from collections.abc import Mapping

MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True)
class CompressionPreset:
    """How chunks are written."""

    name: str
    compression: str
    """MCAP chunk compression: ``""`` (none) or ``"zstd"``."""
    level: int
    """zstd level (ignored without compression)."""
    chunk_size: int
    """Uncompressed bytes after which a chunk is closed."""


PRESETS: dict[str, CompressionPreset] = {
    # 768 KiB: the MCAP C++ writer's default chunk size, which rosbag2 keeps.
    "none": CompressionPreset("none", "", 0, 768 * 1024),
    "zstd_fast": CompressionPreset("zstd_fast", "zstd", 1, 768 * 1024),
    # rosbag2's zstd_small: 4 MiB chunks at the strongest level; 22 takes ~20 s per 15 MB
    # here, 19 compresses nearly as well in a few seconds.
    "zstd_small": CompressionPreset("zstd_small", "zstd", 19, 4 * 1024 * 1024),
}
DEFAULT_PRESET = "zstd_fast"


class McapWriter:
    """Writes one MCAP file (profile ``ros2``); ``close()`` writes the summary and footer."""

    def __init__(
        self,
        stream: BinaryIO,
        preset: CompressionPreset,
        *,
        library: str = "wildfire_msgs_py",
        chunk_period_s: float | None = None,
    ) -> None:
        self._stream = stream
        self.preset = preset
        self._compressor = (
            zstandard.ZstdCompressor(level=preset.level) if preset.compression == "zstd" else None
        )
        self._chunk_period_s = chunk_period_s
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._sequences: dict[int, int] = {}
        self._counts: dict[int, int] = {}
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._start_ns: int | None = None
        self._end_ns = 0
        self._chunk = RecordBuilder()
        self._chunk_messages = 0
        self._chunk_start_ns = 0
        self._chunk_end_ns = 0
        self._chunk_opened = 0.0
        self._message_indexes: dict[int, list[tuple[int, int]]] = {}
        self.compressed_bytes = 0
        self.uncompressed_bytes = 0
        self._stream.write(MAGIC)
        self._emit(Header(profile="ros2", library=library))
        self._stream.flush()

    def _emit(self, record: Header | Schema | Channel | Metadata | DataEnd) -> int:
        """Write one record to the data section; return its offset."""
        builder = RecordBuilder()
        record.write(builder)
        offset = self._stream.tell()
        self._stream.write(builder.end())
        return offset

    def add_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Register a schema; returns its id."""
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._emit(schema)
        self._stream.flush()
        return schema.id

    def add_channel(
        self, topic: str, schema_id: int, message_encoding: str, metadata: Mapping[str, str]
    ) -> int:
        """Register a channel; returns its id."""
        channel = Channel(
            id=len(self._channels) + 1,
            topic=topic,
            message_encoding=message_encoding,
            schema_id=schema_id,
            metadata=dict(metadata),
        )
        self._channels.append(channel)
        self._counts[channel.id] = 0
        self._emit(channel)
        self._stream.flush()
        return channel.id

    def write(
        self,
        channel_id: int,
        log_time_ns: int,
        data: bytes,
        *,
        publish_time_ns: int | None = None,
        sequence: int | None = None,
    ) -> None:
        """Append one message to the open chunk (closing it when full or due)."""
        if sequence is None:
            sequence = self._sequences.get(channel_id, 0) + 1
        self._sequences[channel_id] = sequence
        self._counts[channel_id] += 1
        if self._chunk_messages == 0:
            self._chunk_start_ns = self._chunk_end_ns = log_time_ns
            self._chunk_opened = time.monotonic()
        self._chunk_start_ns = min(self._chunk_start_ns, log_time_ns)
        self._chunk_end_ns = max(self._chunk_end_ns, log_time_ns)
        self._start_ns = log_time_ns if self._start_ns is None else min(self._start_ns, log_time_ns)
        self._end_ns = max(self._end_ns, log_time_ns)
        self._message_indexes.setdefault(channel_id, []).append((log_time_ns, self._chunk.count))
        Message(
            channel_id=channel_id,
            log_time=log_time_ns,
            publish_time=log_time_ns if publish_time_ns is None else publish_time_ns,
            sequence=sequence & 0xFFFFFFFF,
            data=data,
        ).write(self._chunk)
        self._chunk_messages += 1
        if self._chunk.count >= self.preset.chunk_size:
            self.flush()
        else:
            self.flush_if_due()

    def flush_if_due(self) -> None:
        """Close the open chunk if it is older than the chunk period."""
        if (
            self._chunk_period_s is not None
            and self._chunk_messages
            and time.monotonic() - self._chunk_opened >= self._chunk_period_s
        ):
            self.flush()

    def flush(self) -> None:
        """Close the open chunk (with its message indexes) and push it to the OS."""
        if not self._chunk_messages:
            return
        raw = self._chunk.end()
        data = raw if self._compressor is None else self._compressor.compress(raw)
        builder = RecordBuilder()
        Chunk(
            message_start_time=self._chunk_start_ns,
            message_end_time=self._chunk_end_ns,
            uncompressed_size=len(raw),
            uncompressed_crc=zlib.crc32(raw),
            compression=self.preset.compression,
            data=data,
        ).write(builder)
        chunk_length = builder.count
        offsets: dict[int, int] = {}
        for channel_id, records in self._message_indexes.items():
            offsets[channel_id] = builder.count
            MessageIndex(channel_id=channel_id, records=records).write(builder)
        index_length = builder.count - chunk_length
        start = self._stream.tell()
        self._stream.write(builder.end())
        self._stream.flush()
        self._chunk_indexes.append(
            ChunkIndex(
                message_start_time=self._chunk_start_ns,
                message_end_time=self._chunk_end_ns,
                chunk_start_offset=start,
                chunk_length=chunk_length,
                message_index_offsets={c: start + o for c, o in offsets.items()},
                message_index_length=index_length,
                compression=self.preset.compression,
                compressed_size=len(data),
                uncompressed_size=len(raw),
            )
        )
        self.compressed_bytes += len(data)
        self.uncompressed_bytes += len(raw)
        self._message_indexes = {}
        self._chunk_messages = 0

    def add_metadata(self, name: str, metadata: Mapping[str, str]) -> None:
        """A Metadata record (rosbag2 stores its ``serialized_metadata`` so)."""
        self.flush()
        record = Metadata(name=name, metadata=dict(metadata))
        offset = self._emit(record)
        self._metadata_indexes.append(
            MetadataIndex(offset=offset, length=self._stream.tell() - offset, name=name)
        )

    def close(self) -> None:
        """Close the open chunk, then write the summary section, the footer and the magic."""
        self.flush()
        self._emit(DataEnd(data_section_crc=0))
        summary_start = self._stream.tell()
        summary = RecordBuilder()
        offsets: list[SummaryOffset] = []

        def group(opcode: Opcode, records: list[Schema] | list[Channel] | list[ChunkIndex]) -> None:
            if not records:
                return
            begin = summary.count
            for record in records:
                record.write(summary)
            offsets.append(SummaryOffset(opcode, summary_start + begin, summary.count - begin))

        group(Opcode.SCHEMA, self._schemas)
        group(Opcode.CHANNEL, self._channels)
        begin = summary.count
        Statistics(
            message_count=sum(self._counts.values()),
            schema_count=len(self._schemas),
            channel_count=len(self._channels),
            attachment_count=0,
            metadata_count=len(self._metadata_indexes),
            chunk_count=len(self._chunk_indexes),
            message_start_time=self._start_ns or 0,
            message_end_time=self._end_ns,
            channel_message_counts=dict(self._counts),
        ).write(summary)
        offsets.append(
            SummaryOffset(Opcode.STATISTICS, summary_start + begin, summary.count - begin)
        )
        group(Opcode.CHUNK_INDEX, self._chunk_indexes)
        if self._metadata_indexes:
            begin = summary.count
            for index in self._metadata_indexes:
                index.write(summary)
            offsets.append(
                SummaryOffset(Opcode.METADATA_INDEX, summary_start + begin, summary.count - begin)
            )
        summary_offset_start = summary_start + summary.count
        for offset in offsets:
            offset.write(summary)
        data = summary.end()
        crc = zlib.crc32(data)
        crc = zlib.crc32(
            struct.pack("<BQQQ", Opcode.FOOTER, 20, summary_start, summary_offset_start), crc
        )
        self._stream.write(data)
        footer = RecordBuilder()
        Footer(
            summary_start=summary_start, summary_offset_start=summary_offset_start, summary_crc=crc
        ).write(footer)
        self._stream.write(footer.end())
        self._stream.write(MAGIC)
        self._stream.flush()


__all__ = ["DEFAULT_PRESET", "PRESETS", "CompressionPreset", "McapWriter"]
