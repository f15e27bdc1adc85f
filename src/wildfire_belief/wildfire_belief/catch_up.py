"""Catch-up: when a radio link returns, the two replicas exchange what the other missed.

See docs/model.md, Radio links. A replica that hears a peer again after a gap of more than
``CATCH_UP_GAP_TICKS`` (it missed at least that many of the peer's messages, or never heard
it) asks for what it missed:

1. its next radio message carries a **digest** for that peer: per block of a 10 x 10 grid of
   blocks over the map (10 x 10 cells each on the paper's map, bands of ``rows / 10`` by
   ``cols / 10`` cells on any other, so a digest is 100 numbers whatever the map), the
   oldest of the block's last visits in its replica (:func:`digest_of`);
2. the peer, once it hears the digest, answers in its next message with the **missing
   visits**: every cell of its own replica whose visit is newer than the digest's tick for
   the cell's block, with its key, but for the asker's own visits (:func:`missing_visits`).
   Every cell the asker holds older than the peer is among them (its tick is at least its
   block's oldest; a newer visit of the asker's own is already in its replica), so after the
   merge the asker's replica holds everything the peer's held when it answered;
3. the asker merges them like any visit (last writer wins), once it hears the reply.

Digest and reply ride in the ordinary radio messages, under the same radio model; when
either is lost, the asker asks again once it hears the peer a round trip later
(:func:`retry_ticks`). Messages are composed from the replica as it
stands before the tick's own merges, in the environment and in an agent alike.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from wildfire_belief.replicas import KEY_AIRCRAFT, KEY_SHIFT, visit_key
from wildfire_msgs_py.radio_codec import MAX_SECTIONS, Digest, Reply

CATCH_UP_GAP_TICKS = 10
"""A link returns when the heard message follows the previous heard one by more than 1 s."""
BLOCKS_PER_SIDE = 10
"""A digest's blocks per side of the map: 100 blocks in all (``radio_codec.DIGEST_BLOCKS``)."""
DIGEST_TICK_CAP = 2**16 - 1
"""Digest ticks are 16 bits: a later tick reads as the cap, which only adds to the reply."""


def link_returned(previous_tick: np.ndarray | int, sent_tick: np.ndarray | int) -> np.ndarray:
    """Whether a message sent at ``sent_tick`` ends a gap since ``previous_tick`` (heard)."""
    return np.asarray(sent_tick) - np.asarray(previous_tick) > CATCH_UP_GAP_TICKS


def block_of_cells(shape: tuple[int, ...]) -> np.ndarray:
    """(H, W) int64: the digest block of every cell, row band ``row * 10 // H`` times 10 plus
    column band ``col * 10 // W`` (on the paper's 100 x 100 map, blocks of 10 x 10 cells)."""
    rows, cols = int(shape[-2]), int(shape[-1])
    band_row = np.arange(rows, dtype=np.int64) * BLOCKS_PER_SIDE // rows
    band_col = np.arange(cols, dtype=np.int64) * BLOCKS_PER_SIDE // cols
    return band_row[:, None] * BLOCKS_PER_SIDE + band_col[None, :]


def digest_of(key: np.ndarray) -> np.ndarray:
    """(100,) uint16: per block of a replica's (H, W) keys, the oldest last-visit tick of
    its cells (0 while a cell was never visited)."""
    ticks = np.clip(key >> KEY_SHIFT, 0, DIGEST_TICK_CAP)
    blocks = np.full(BLOCKS_PER_SIDE**2, DIGEST_TICK_CAP, dtype=np.int64)
    np.minimum.at(blocks, block_of_cells(key.shape).reshape(-1), ticks.reshape(-1))
    return blocks.astype(np.uint16)


def missing_visits(
    key: np.ndarray, burning: np.ndarray, digest: np.ndarray, asker: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cells of a replica (H, W) newer than ``digest`` says aircraft ``asker`` holds: flat
    cell indices, their visit keys and burning values (in cell order). The asker's own
    visits are left out: its replica merged each of them the moment it made it."""
    per_cell = np.asarray(digest, np.int64)[block_of_cells(key.shape).reshape(-1)]
    flat = key.reshape(-1)
    newer = (flat >> KEY_SHIFT > per_cell) & (flat & (KEY_AIRCRAFT - 1) != asker)
    cells = np.flatnonzero(newer)
    return cells, flat[cells], burning.reshape(-1)[cells]


def make_reply(target: int, key: np.ndarray, burning: np.ndarray, digest: np.ndarray) -> Reply:
    """The reply to ``target``'s digest from a replica's (H, W) keys and burning values."""
    cells, keys, values = missing_visits(key, burning, digest, target)
    return Reply(
        target,
        cells.astype(np.uint32),
        (keys >> KEY_SHIFT).astype(np.uint32),
        (keys & (KEY_AIRCRAFT - 1)).astype(np.uint8),
        values,
    )


def reply_keys(reply: Reply) -> np.ndarray:
    """The visit keys of a reply's cells."""
    return visit_key(reply.ticks.astype(np.int64), reply.aircraft.astype(np.int64))


def retry_ticks(delay: int) -> int:
    """Ticks after a digest before asking again: a round trip (digest, then reply, each a
    tick to compose and ``delay`` to arrive) and a margin."""
    return 2 * (delay + 1) + 3


class CatchUpQueue:
    """One aircraft's catch-ups: the digests and replies it owes its peers in its next
    messages, and the digests still awaiting a reply.

    ``asks`` are the peers to send a digest to; ``answers`` maps a peer to the digest it sent
    (the newest); ``waiting`` maps a peer to the tick of the last digest sent to it until its
    reply arrives. A digest or reply lost on the radio is asked again once the peer is heard
    ``retry`` ticks after the digest. At most ``MAX_SECTIONS`` of each go out per message,
    lowest peer first.
    """

    def __init__(self, retry: int) -> None:
        self.retry = retry
        self.asks: set[int] = set()
        self.answers: dict[int, np.ndarray] = {}
        self.waiting: dict[int, int] = {}

    def on_heard(self, peer: int, tick: int, returned: bool) -> None:
        """Peer ``peer`` heard at ``tick``; ``returned``: its message ended a gap."""
        late = peer in self.waiting and tick - self.waiting[peer] >= self.retry
        if returned or late:
            self.asks.add(peer)

    def on_digest(self, peer: int, block_ticks: np.ndarray) -> None:
        self.answers[peer] = block_ticks

    def on_reply(self, peer: int) -> None:
        self.waiting.pop(peer, None)

    def compose(
        self, tick: int, key: np.ndarray, burning: np.ndarray
    ) -> tuple[tuple[Digest, ...], tuple[Reply, ...]]:
        """The digests and replies of the message of ``tick``, from the replica's keys and
        values as they stand."""
        return self.compose_with(
            tick,
            lambda _peer: digest_of(key),
            lambda peer, digest: make_reply(peer, key, burning, digest),
        )

    def compose_with(
        self,
        tick: int,
        digest: Callable[[int], np.ndarray],
        reply: Callable[[int, np.ndarray], Reply],
    ) -> tuple[tuple[Digest, ...], tuple[Reply, ...]]:
        """The digests and replies of the message of ``tick``, made by ``digest(peer)`` (the
        block ticks to send ``peer``) and ``reply(peer, block_ticks)`` (the answer to
        ``peer``'s digest): the replica's own way of saying what it holds."""
        asks = sorted(self.asks)[:MAX_SECTIONS]
        answers = sorted(self.answers)[:MAX_SECTIONS]
        self.asks -= set(asks)
        self.waiting |= dict.fromkeys(asks, tick)
        digests = tuple(Digest(j, digest(j)) for j in asks)
        replies = tuple(reply(j, self.answers.pop(j)) for j in answers)
        return digests, replies


__all__ = [
    "BLOCKS_PER_SIDE",
    "CATCH_UP_GAP_TICKS",
    "DIGEST_TICK_CAP",
    "CatchUpQueue",
    "digest_of",
    "link_returned",
    "make_reply",
    "missing_visits",
    "reply_keys",
    "retry_ticks",
]
