"""Rewrite bags: recover a truncated recording (``reindex``), re-compress one (``convert``).

A recorder killed with SIGKILL (or a full disk, or a power cut) leaves an MCAP file without its
summary and no ``metadata.yaml``. Every chunk closed before that is complete on disk (the
writer closes one at least every ``chunk_period_s``) and carries a CRC, so :func:`reindex`
reads the file front to back, keeps every schema, channel and message of the chunks whose CRC
holds, stops at the first damaged or partial record, and writes a finalized bag with those
messages and a new ``metadata.yaml`` — what ``ros2 bag reindex`` does for files that still
have their indexes. The damaged file is kept beside it as ``<name>.mcap.truncated``.

:func:`convert` copies a readable bag record for record (log and publish times, sequence
numbers, schemas, offered QoS) with another compression preset, and fills in what older
bags lack: the RIHS01 type hash where the type is known, Jazzy metadata.
"""

from __future__ import annotations

import itertools
import shutil
import struct
import tempfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import zstandard
from mcap.exceptions import McapError
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import CRCValidationError, StreamReader, breakup_chunk

from wildfire_msgs_py.errors import BagError
from wildfire_ros.bag import (
    PRESET_KEY,
    BagWriter,
    open_reader,
    parse_offered_qos,
    read_custom_data,
)
from wildfire_ros.mcap_writer import DEFAULT_PRESET, PRESETS

if TYPE_CHECKING:
    from collections.abc import Iterator

# What a damaged file can raise while it is read record by record.
_DAMAGE = (
    McapError,
    CRCValidationError,
    struct.error,
    zstandard.ZstdError,
    zlib.error,
    EOFError,
    ValueError,
    KeyError,
    IndexError,
    OSError,
    MemoryError,
    UnicodeDecodeError,
)


@dataclass(frozen=True)
class RewriteResult:
    """What a rewrite kept."""

    path: Path
    messages: int
    topics: int
    complete: bool
    """True when the source file ended with its footer (nothing was lost)."""
    kept_original: Path | None = None
    """Where the damaged source file was moved (``reindex``)."""


@dataclass
class _Scan:
    schemas: dict[int, Schema]
    channels: dict[int, Channel]
    custom_data: dict[str, str]
    compression: str = ""
    complete: bool = False


def _records(file: Path, scan: _Scan) -> Iterator[tuple[Channel, Schema | None, Message]]:
    """Messages of an MCAP file in file order, stopping quietly at the first damage."""
    with file.open("rb") as stream:
        reader = StreamReader(stream, validate_crcs=True, emit_chunks=True)
        records = reader.records
        while True:
            try:
                record = next(records)
                inner = _chunk_records(record, scan) if isinstance(record, Chunk) else [record]
            except StopIteration:
                return
            except _DAMAGE:
                return  # a partial or damaged record: everything before it is kept
            for item in inner:
                if isinstance(item, Schema):
                    scan.schemas[item.id] = item
                elif isinstance(item, Channel):
                    scan.channels[item.id] = item
                elif isinstance(item, Metadata) and item.name == "wildfire":
                    scan.custom_data.update(item.metadata)
                elif isinstance(item, (DataEnd, Footer)):
                    scan.complete = True
                elif isinstance(item, Message) and item.channel_id in scan.channels:
                    channel = scan.channels[item.channel_id]
                    yield channel, scan.schemas.get(channel.schema_id), item


def _chunk_records(chunk: Chunk, scan: _Scan) -> list[object]:
    """The records of a chunk, all or nothing (its CRC is checked)."""
    records = breakup_chunk(chunk, validate_crc=True)
    scan.compression = scan.compression or chunk.compression
    return list(records)


def _copy(source: Path, output: Path, compression: str | None, custom: dict[str, str]) -> _Scan:
    """Copy the readable records of ``source`` into a new bag at ``output``."""
    scan = _Scan({}, {}, dict(custom))
    messages = _records(source, scan)
    first = next(messages, None)
    # The preset of the copy: asked for, else the source's (a scan learns it from the chunks).
    preset = (
        compression
        or scan.custom_data.get(PRESET_KEY)
        or (DEFAULT_PRESET if scan.compression == "zstd" else "none")
    )
    if preset not in PRESETS:
        preset = DEFAULT_PRESET
    data = {k: v for k, v in scan.custom_data.items() if k != PRESET_KEY}
    writer = BagWriter(output, compression=preset, custom_data=data)
    try:
        for channel, schema, message in itertools.chain([first] if first else [], messages):
            if not writer.has_topic(channel.topic):
                writer.add_topic(
                    channel.topic,
                    schema.name if schema is not None else "",
                    offered_qos=parse_offered_qos(channel.metadata.get("offered_qos_profiles", "")),
                    schema=None if schema is None else (schema.encoding, schema.data),
                    hash_rihs01=channel.metadata.get("topic_type_hash") or None,
                )
            writer.write(
                channel.topic,
                message.log_time,
                message.data,
                publish_time_ns=message.publish_time,
                sequence=message.sequence or None,
            )
    finally:
        writer.close()
    return scan


def _single_mcap(bag: Path) -> Path:
    if not bag.is_dir():
        raise BagError(f"bag {bag}: no such directory")
    files = sorted(bag.glob("*.mcap"))
    if len(files) != 1:
        found = ", ".join(f.name for f in files) or "none"
        raise BagError(f"bag {bag}: expected one .mcap file, found {found}")
    return files[0]


def reindex(bag_dir: str | Path) -> RewriteResult:
    """Recover the complete chunks of a bag's MCAP file and write its ``metadata.yaml``."""
    bag = Path(bag_dir)
    source = _single_mcap(bag)
    custom = read_custom_data(bag) if (bag / "metadata.yaml").is_file() else {}
    work = Path(tempfile.mkdtemp(prefix=f".{bag.name}-reindex-", dir=bag.parent))
    try:
        try:
            scan = _copy(source, work / bag.name, None, custom)
        except BagError:
            raise
        except _DAMAGE as error:
            raise BagError(f"bag {bag}: {source.name} is not an MCAP file ({error})") from None
        if not scan.channels:
            raise BagError(f"bag {bag}: {source.name} holds no complete chunk to recover")
        kept = source.with_name(source.name + ".truncated")
        source.replace(kept)
        for item in (work / bag.name).iterdir():
            item.replace(bag / item.name)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    info = open_reader(bag)
    try:
        return RewriteResult(bag, info.message_count, len(info.connections), scan.complete, kept)
    finally:
        info.close()


def convert(source_dir: str | Path, output_dir: str | Path, compression: str) -> RewriteResult:
    """Copy a readable bag into a new one written with another compression preset."""
    source = Path(source_dir)
    output = Path(output_dir)
    if compression not in PRESETS:
        raise BagError(f"compression {compression!r}: expected one of {', '.join(PRESETS)}")
    open_reader(source).close()  # a missing or damaged input is named in one line
    if output.exists():
        raise BagError(f"bag output {output}: already exists, expected a new directory")
    scan = _copy(_single_mcap(source), output, compression, read_custom_data(source))
    info = open_reader(output)
    try:
        return RewriteResult(output, info.message_count, len(info.connections), scan.complete)
    finally:
        info.close()


__all__ = ["RewriteResult", "convert", "reindex"]
