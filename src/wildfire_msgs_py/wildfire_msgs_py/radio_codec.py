"""Radio messages between aircraft <-> ``std_msgs/UInt8MultiArray`` (topic ``/uavK/radio``).

A radio link is narrow, so a decision's message is packed bytes, not a grid (little endian,
no padding):

=======  =====  ============================================================================
offset   type   field
=======  =====  ============================================================================
0        u32    tick of the decision (stamp = tick x 0.1 s)
4        u8     sender's aircraft index
5        i8     bank in 5 degree steps
6        3 f64  x_m, y_m, heading_rad (exact: peers dead-reckon and build pairwise states
                from them)
30       u8     catch-up sections: digests (high nibble) and replies (low nibble) that follow
31       ...    the digests, then the replies (below)
...      bits   burning value of each visited cell, row-major over the window, packed 8 per
                byte (``numpy.packbits``, most significant bit first), to the end
=======  =====  ============================================================================

The visit window and which of its cells are visited follow from the position (the 21 x 21
cells around the aircraft's cell; every cell whose centre lies within 100 m, inside the map),
so neither travels: only the visited cells' burning bits, about 40 bytes for the ~314 cells
of a full disc, 71 bytes in all, 87 with the message's CDR framing. The receiver recomputes
the window and checks the number of bits (``wildfire_agent.aircraft_radio``).

Catch-up (rare: when a link returns after a gap) rides in the same messages:

* a **digest** for peer ``target``: u8 target, then for each of the 100 blocks of a 10 x 10
  grid of blocks over the map (``wildfire_belief.catch_up``) the oldest last visit tick the
  sender's replica holds there (u16, 0 for none): 201 bytes on any map;
* a **reply** to peer ``target``: u8 target, u32 count, u32 size, then ``size`` bytes of zlib
  (level 9) over the ``count`` cells in index order: their flat indices as differences from
  the previous one (u32: a field map has millions of cells), their visit ticks as differences
  likewise (i32), their aircraft (u8) and their burning bits (packed). Neighbouring cells
  were mostly visited together, so the differences repeat: about 0.8 byte per cell, against
  9 raw.
"""

from __future__ import annotations

import array
import struct
import zlib
from typing import Any, NamedTuple

import numpy as np

from wildfire_msgs_py.codecs import _message
from wildfire_msgs_py.errors import MessageFieldError

HEADER = struct.Struct("<IBb3dB")
"""tick, aircraft, bank_steps, x_m, y_m, heading_rad, sections."""
REPLY_HEADER = struct.Struct("<BII")
"""A reply's target, cell count and compressed size."""
MAX_TICK = 2**32 - 1
DIGEST_BLOCKS = 100
"""Blocks of a digest: any map in a 10 x 10 grid of blocks (10 x 10 cells on the paper's)."""
MAX_SECTIONS = 15
"""Digests (and replies) one message carries at most; more wait for the next."""


class Digest(NamedTuple):
    """What the sender's replica holds: the newest visit tick per block (0: none)."""

    target: int
    block_ticks: np.ndarray
    """(100,) uint16."""


class Reply(NamedTuple):
    """The visits a peer's digest showed it lacks, with their keys."""

    target: int
    cells: np.ndarray
    """Flat cell indices (uint32)."""
    ticks: np.ndarray
    """Visit tick of each cell (uint32)."""
    aircraft: np.ndarray
    """Visiting aircraft of each cell (uint8)."""
    burning: np.ndarray
    """Burning value of each cell (bool)."""


class RadioMessage(NamedTuple):
    """One aircraft's radio message of one decision."""

    tick: int
    aircraft: int
    x_m: float
    y_m: float
    heading_rad: float
    bank_steps: int
    bits: np.ndarray
    """Packed burning bits of the visited cells (uint8)."""
    digests: tuple[Digest, ...] = ()
    replies: tuple[Reply, ...] = ()

    def burning(self, count: int) -> np.ndarray:
        """The burning values of the ``count`` visited cells (bool)."""
        return np.unpackbits(self.bits, count=count).astype(bool)


def pack_burning(burning: np.ndarray) -> np.ndarray:
    """Packed bits of the visited cells' burning values (in their row-major order)."""
    return np.packbits(np.asarray(burning, dtype=bool))


def radio_to_bytes(message: RadioMessage) -> bytes:
    if len(message.digests) > MAX_SECTIONS or len(message.replies) > MAX_SECTIONS:
        raise ValueError(f"at most {MAX_SECTIONS} digests and replies per radio message")
    parts = [
        HEADER.pack(
            message.tick,
            message.aircraft,
            message.bank_steps,
            message.x_m,
            message.y_m,
            message.heading_rad,
            len(message.digests) << 4 | len(message.replies),
        )
    ]
    for digest in message.digests:
        parts += [bytes([digest.target]), np.asarray(digest.block_ticks, "<u2").tobytes()]
    for reply in message.replies:
        payload = zlib.compress(_reply_payload(reply), 9)
        parts += [REPLY_HEADER.pack(reply.target, len(reply.cells), len(payload)), payload]
    parts.append(np.asarray(message.bits, dtype=np.uint8).tobytes())
    return b"".join(parts)


def _reply_payload(reply: Reply) -> bytes:
    cells = np.asarray(reply.cells, np.int64)
    ticks = np.asarray(reply.ticks, np.int64)
    return b"".join(
        [
            # Signed steps: a disc reply's cells ascend, a camera reply's go report by report.
            np.diff(cells, prepend=0).astype("<i4").tobytes(),
            np.diff(ticks, prepend=0).astype("<i4").tobytes(),
            np.asarray(reply.aircraft, "u1").tobytes(),
            np.packbits(np.asarray(reply.burning, bool)).tobytes(),
        ]
    )


def _reply_from_payload(target: int, count: int, compressed: bytes) -> Reply:
    """A reply from its compressed payload; one that inflates to another size is malformed
    (and inflating stops at the expected size: no zip bomb gets further)."""
    expected = 9 * count + (count + 7) // 8
    try:
        payload = zlib.decompressobj().decompress(compressed, expected + 1)
    except zlib.error as error:
        raise MessageFieldError(f"catch-up reply does not inflate: {error}") from None
    if len(payload) != expected:
        raise MessageFieldError(f"catch-up reply of {len(payload)} bytes for {count} cells")
    reader = _Reader(payload, 0)
    cells = np.cumsum(reader.array(count, "<i4").astype(np.int64))
    ticks = np.cumsum(reader.array(count, "<i4").astype(np.int64))
    aircraft = reader.array(count, "u1")
    burning = np.unpackbits(reader.array((count + 7) // 8, "u1"), count=count).astype(bool)
    if count and (min(ticks.min(), cells.min()) < 0 or max(ticks.max(), cells.max()) >= 2**32):
        raise MessageFieldError("catch-up reply with cells or ticks out of range")
    return Reply(target, cells.astype(np.uint32), ticks.astype(np.uint32), aircraft, burning)


class _Reader:
    """Reads consecutive fields of a packed message; too few bytes is malformed."""

    def __init__(self, data: bytes, offset: int) -> None:
        self.data, self.offset = data, offset

    def take(self, size: int) -> bytes:
        if self.offset + size > len(self.data):
            raise MessageFieldError(f"radio message of {len(self.data)} bytes ends early")
        chunk = self.data[self.offset : self.offset + size]
        self.offset += size
        return chunk

    def array(self, count: int, dtype: str) -> np.ndarray:
        size = np.dtype(dtype).itemsize
        return np.frombuffer(self.take(count * size), dtype=dtype).copy()


def radio_from_bytes(data: bytes) -> RadioMessage:
    """The message in ``data``; :class:`MessageFieldError` when it is too short."""
    if len(data) < HEADER.size:
        raise MessageFieldError(f"radio message of {len(data)} bytes, expected >= {HEADER.size}")
    tick, aircraft, bank, x, y, heading, sections = HEADER.unpack_from(data)
    reader = _Reader(data, HEADER.size)
    digests = tuple(
        Digest(reader.take(1)[0], reader.array(DIGEST_BLOCKS, "<u2")) for _ in range(sections >> 4)
    )
    replies = []
    for _ in range(sections & 0xF):
        target, count, size = REPLY_HEADER.unpack(reader.take(REPLY_HEADER.size))
        replies.append(_reply_from_payload(target, count, reader.take(size)))
    bits = np.frombuffer(data, dtype=np.uint8, offset=reader.offset).copy()
    return RadioMessage(tick, aircraft, x, y, heading, bank, bits, digests, tuple(replies))


def radio_to_msg(message: RadioMessage, message_class: Any = None) -> Any:
    """Radio message -> ``std_msgs/UInt8MultiArray`` (``data`` the packed bytes)."""
    msg = _message("std_msgs/msg/UInt8MultiArray", message_class)
    msg.data = array.array("B", radio_to_bytes(message))
    return msg


def radio_from_msg(msg: Any) -> RadioMessage:
    return radio_from_bytes(bytes(msg.data))


__all__ = [
    "DIGEST_BLOCKS",
    "HEADER",
    "MAX_SECTIONS",
    "MAX_TICK",
    "Digest",
    "RadioMessage",
    "Reply",
    "pack_burning",
    "radio_from_bytes",
    "radio_from_msg",
    "radio_to_bytes",
    "radio_to_msg",
]
