"""The radio links between aircraft (docs/model.md, Radio links): which message arrives, when.

Every decision each aircraft broadcasts one radio message: its pose and the cells it visited
at that tick. Whether aircraft ``i`` hears the message aircraft ``j`` sent at tick ``t`` is
decided by a :class:`CommModel`, with no state beyond the episode seed:

* ``ideal``: every message arrives at once (the paper's shared belief; the default);
* ``none``: no message ever arrives;
* ``range=R,loss=P,delay=D``: the message arrives at tick ``t + D`` when the two aircraft are
  at most ``R`` metres apart at tick ``t`` and the link's draw for that tick is at least
  ``P`` (independent loss per message and link);
* ``outage=A-B`` (with any of the above): no message sent from ``A`` s to ``B`` s of flight
  arrives (a partition of the whole team, e.g. to measure how replicas catch up).

The draws are seeded per link, ``generator(seed, RADIO, j, i, block)`` for blocks of
``DRAW_BLOCK`` ticks, and addressed by tick: the environment (a batch of episodes) and an
agent node (one receiver) read the same numbers whatever they computed before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wildfire_belief.belief import TICKS_PER_S
from wildfire_sim.seeding import Stream, generator

DRAW_BLOCK = 1024
"""Ticks of loss draws generated at a time per link (counter-addressed, so any order works)."""
MAX_DELAY_DECISIONS = 600
"""Longest delay a model may have (60 s): messages in flight are buffered that long."""
COMM_KEYS = ("range", "loss", "delay", "outage")
"""Keys of a radio model's ``key=value`` description."""


class CommError(ValueError):
    """A malformed radio model description."""


@dataclass(frozen=True)
class CommModel:
    """Radio links of a team (see the module docstring). ``CommModel()`` is ``ideal``."""

    range_m: float = math.inf
    """Messages carry this far (metres, between the aircraft at the send tick)."""
    loss: float = 0.0
    """Probability that a message is lost on one link, independently per message."""
    delay: int = 0
    """Decisions between sending and hearing a message."""
    links: bool = True
    """False for ``none``: nothing is ever heard."""
    outage_s: tuple[float, float] | None = None
    """Flight seconds [start, end) during which no message arrives."""

    @property
    def ideal(self) -> bool:
        """Every message arrives at once: the team shares one belief, as in the paper."""
        perfect = self.range_m == math.inf and self.loss == 0.0 and self.delay == 0
        return self.links and perfect and self.outage_s is None

    @classmethod
    def parse(cls, text: str) -> CommModel:
        """``ideal``, ``none`` or ``range=R[,loss=P][,delay=D][,outage=A-B]`` (any of the keys)."""
        text = text.strip()
        if text == "ideal":
            return cls()
        if text == "none":
            return cls(links=False)
        values: dict[str, str] = {}
        for item in text.split(","):
            key, sep, value = item.partition("=")
            key = key.strip()
            if not sep or key not in COMM_KEYS:
                raise CommError(
                    f"comm {text!r}: expected ideal, none or key=value items with keys "
                    f"{', '.join(COMM_KEYS)} (e.g. range=300,loss=0.2,delay=2,outage=60-90), "
                    f"got {item!r}"
                )
            if key in values:
                raise CommError(f"comm {text!r}: {key} given twice")
            values[key] = value.strip()
        try:
            range_m = float(values.get("range", "inf"))
            loss = float(values.get("loss", "0"))
            delay = int(values.get("delay", "0"))
            outage = None
            if "outage" in values:
                start, _, end = values["outage"].partition("-")
                outage = (float(start), float(end))
        except ValueError:
            raise CommError(
                f"comm {text!r}: expected range in metres, loss a probability, delay "
                "a whole number of decisions and outage START-END in seconds"
            ) from None
        if outage is not None and not 0.0 <= outage[0] < outage[1]:
            raise CommError(f"comm {text!r}: outage expected 0 <= START < END seconds")
        if not range_m >= 0.0:
            raise CommError(f"comm {text!r}: range expected >= 0 m, got {range_m}")
        if not 0.0 <= loss <= 1.0:
            raise CommError(f"comm {text!r}: loss expected in [0, 1], got {loss}")
        if not 0 <= delay <= MAX_DELAY_DECISIONS:
            raise CommError(
                f"comm {text!r}: delay expected 0..{MAX_DELAY_DECISIONS} decisions, got {delay}"
            )
        return cls(range_m=range_m, loss=loss, delay=delay, outage_s=outage)

    def __str__(self) -> str:
        """The canonical description, which :meth:`parse` reads back."""
        if not self.links:
            return "none"
        if self.ideal:
            return "ideal"
        items = []
        if self.range_m != math.inf:
            items.append(f"range={self.range_m:g}")
        if self.loss:
            items.append(f"loss={self.loss:g}")
        if self.delay:
            items.append(f"delay={self.delay}")
        if self.outage_s is not None:
            items.append(f"outage={self.outage_s[0]:g}-{self.outage_s[1]:g}")
        return ",".join(items)


IDEAL = CommModel()


def link_draws(seed: int, sender: int, receiver: int, block: int) -> np.ndarray:
    """The uniform draws of link ``sender -> receiver`` for ticks of ``block``, (DRAW_BLOCK,)."""
    return generator(seed, Stream.RADIO, sender, receiver, block).random(DRAW_BLOCK)


class LinkDraws:
    """Loss draws of every link of ``num_envs`` episodes of ``n`` aircraft, by tick.

    Holds one block of ``DRAW_BLOCK`` ticks per episode and link and draws the next when a
    tick leaves it, so memory stays small and each episode's numbers depend on its seed only.
    """

    def __init__(self, num_envs: int, n: int) -> None:
        self.n = n
        self.draws = np.zeros((num_envs, n, n, DRAW_BLOCK))
        self.key = np.full((num_envs, 2), -1, dtype=np.int64)
        """(seed, block) each episode's draws belong to."""

    def at(self, seeds: np.ndarray, ticks: np.ndarray) -> np.ndarray:
        """(E, N, N) draws ``[e, sender, receiver]`` of tick ``ticks[e]`` (diagonal unused)."""
        seeds = np.asarray(seeds, dtype=np.int64)
        ticks = np.asarray(ticks, dtype=np.int64)
        blocks = ticks // DRAW_BLOCK
        stale = np.flatnonzero((self.key[:, 0] != seeds) | (self.key[:, 1] != blocks))
        for e in stale.tolist():
            seed, block = int(seeds[e]), int(blocks[e])
            for j in range(self.n):
                for i in range(self.n):
                    if i != j:
                        self.draws[e, j, i] = link_draws(seed, j, i, block)
            self.key[e] = (seed, block)
        env = np.arange(len(ticks))
        return self.draws[env, :, :, ticks % DRAW_BLOCK]


def delivered(
    model: CommModel, draws: np.ndarray, x_m: np.ndarray, y_m: np.ndarray, tick: np.ndarray
) -> np.ndarray:
    """Which messages of one tick arrive: (..., N, N) bool ``[sender, receiver]``.

    ``draws`` are the links' draws of the tick (:class:`LinkDraws`), ``x_m``/``y_m`` (..., N)
    the senders' and receivers' positions when the messages were sent, ``tick`` (...) the
    tick they were sent at. Nobody hears itself over the radio (its own visits are merged
    directly).
    """
    n = x_m.shape[-1]
    others = ~np.eye(n, dtype=bool)
    if not model.links:
        return np.zeros((*x_m.shape, n), dtype=bool)
    dx = x_m[..., :, None] - x_m[..., None, :]
    dy = y_m[..., :, None] - y_m[..., None, :]
    in_range = np.hypot(dx, dy) <= model.range_m
    heard = in_range & (draws >= model.loss) & others
    if model.outage_s is not None:
        start, end = model.outage_s
        seconds = np.asarray(tick)[..., None, None] / TICKS_PER_S
        heard &= ~((seconds >= start) & (seconds < end))
    return heard


__all__ = [
    "COMM_KEYS",
    "DRAW_BLOCK",
    "IDEAL",
    "MAX_DELAY_DECISIONS",
    "CommError",
    "CommModel",
    "LinkDraws",
    "delivered",
    "link_draws",
]
