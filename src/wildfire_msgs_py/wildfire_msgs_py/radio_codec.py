"""Radio messages between aircraft <-> ``std_msgs/UInt8MultiArray`` (topic ``/uavK/radio``).

A radio link is narrow, so a decision's message is packed bytes, not a grid (little endian,
no padding):

=======  =====  ============================================================================
offset   type   field
=======  =====  ============================================================================
0        u32    tick of the decision (stamp = tick x 0.1 s)
4        u8     sender's aircraft index
5        i8     bank in 5 degree steps
6        i16    row of the visit window's south-west cell (may lie off the map)
8        i16    column of that cell
10       3 f64  x_m, y_m, heading_rad (exact: peers dead-reckon and build pairwise states
                from them)
34       bits   burning value of each visited cell, row-major over the window, packed 8 per
                byte (``numpy.packbits``, most significant bit first)
=======  =====  ============================================================================

Which cells of the 21 x 21 window are visited follows from the position (every cell whose
centre lies within 100 m, inside the map), so only their burning bits travel: about 40 bytes
for the ~314 cells of a full disc, 74 bytes in all, 90 with the message's CDR framing.
The receiver recomputes the visited cells and checks the origin and the number of bits
(``wildfire_agent.aircraft_radio``).
"""

from __future__ import annotations

import array
import struct
from typing import Any, NamedTuple

import numpy as np

from wildfire_msgs_py.codecs import _message
from wildfire_msgs_py.errors import MessageFieldError

HEADER = struct.Struct("<IBbhh3d")
"""tick, aircraft, bank_steps, row0, col0, x_m, y_m, heading_rad."""
MAX_TICK = 2**32 - 1


class RadioMessage(NamedTuple):
    """One aircraft's radio message of one decision."""

    tick: int
    aircraft: int
    x_m: float
    y_m: float
    heading_rad: float
    bank_steps: int
    row0: int
    col0: int
    bits: np.ndarray
    """Packed burning bits of the visited cells (uint8)."""

    def burning(self, count: int) -> np.ndarray:
        """The burning values of the ``count`` visited cells (bool)."""
        return np.unpackbits(self.bits, count=count).astype(bool)


def pack_burning(burning: np.ndarray) -> np.ndarray:
    """Packed bits of the visited cells' burning values (in their row-major order)."""
    return np.packbits(np.asarray(burning, dtype=bool))


def radio_to_bytes(message: RadioMessage) -> bytes:
    header = HEADER.pack(
        message.tick,
        message.aircraft,
        message.bank_steps,
        message.row0,
        message.col0,
        message.x_m,
        message.y_m,
        message.heading_rad,
    )
    return header + np.asarray(message.bits, dtype=np.uint8).tobytes()


def radio_from_bytes(data: bytes) -> RadioMessage:
    """The message in ``data``; :class:`MessageFieldError` when it is too short."""
    if len(data) < HEADER.size:
        raise MessageFieldError(f"radio message of {len(data)} bytes, expected >= {HEADER.size}")
    tick, aircraft, bank, row0, col0, x, y, heading = HEADER.unpack_from(data)
    bits = np.frombuffer(data, dtype=np.uint8, offset=HEADER.size).copy()
    return RadioMessage(tick, aircraft, x, y, heading, bank, row0, col0, bits)


def radio_to_msg(message: RadioMessage, message_class: Any = None) -> Any:
    """Radio message -> ``std_msgs/UInt8MultiArray`` (``data`` the packed bytes)."""
    msg = _message("std_msgs/msg/UInt8MultiArray", message_class)
    msg.data = array.array("B", radio_to_bytes(message))
    return msg


def radio_from_msg(msg: Any) -> RadioMessage:
    return radio_from_bytes(bytes(msg.data))


__all__ = [
    "HEADER",
    "MAX_TICK",
    "RadioMessage",
    "pack_burning",
    "radio_from_bytes",
    "radio_from_msg",
    "radio_to_bytes",
    "radio_to_msg",
]
