"""The fire simulator's protocol without ROS: acknowledgements in, what to publish out.

:class:`FireProtocol` paces a :class:`~wildfire_sim.episode.FireEpisode` and holds the
acknowledgement barrier, so it can be tested with plain calls
(``tests/test_fire_protocol.py``). Each ``on_*`` method returns the messages it makes due,
in publishing order (:data:`Output`); an acknowledgement to drop raises
:class:`~wildfire_msgs_py.input_guard.RejectedMessage`.

* Lockstep: tick 0 is announced once every expected reporter said ``<name>/ready``; tick
  ``k + 1`` (with its fire step when due and its end check) once every reporter has
  acknowledged tick ``k``. The status of a tick goes out before its clock.
* Real time: :meth:`FireProtocol.on_timer` counts a decision every 100 ms; the status goes
  out at every fire step and at the end.

Once every reporter has finished the last tick (lockstep) or the timer passes the end (real
time) the status carries ``complete``. An acknowledgement from an unknown reporter (refused
by ``wire_checks.checked_ack``), of a tick not yet announced or of one already acknowledged
is refused. In lockstep the node's status on ``/diagnostics`` carries where the ticks' wall
time went so far (``split_*``, :mod:`wildfire_sim.tick_split`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import NamedTuple

import numpy as np

from wildfire_msgs_py.codecs import NodeStatus
from wildfire_msgs_py.grid_tiles import WHOLE_EVERY_STEPS, Tile, changed_tiles
from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.system_codecs import READY_SUFFIX
from wildfire_sim.episode import DECISION_PERIOD_NS, FireEpisode, Mode
from wildfire_sim.tick_split import TickSplit

NAME = "fire_simulator"
STATUS_EVERY_TICKS = 10
"""The node's status goes to ``/diagnostics`` once a second of flight and at the end."""


class MapsOut(NamedTuple):
    """The true fire and fuel grids of the current fire step."""

    stamp: int
    burning: np.ndarray
    fuel: np.ndarray
    fuel_tiles: list[Tile] | None = None
    """The tiles of the fuel that changed since the last fuel sent, to send instead of the
    whole fuel (:mod:`wildfire_msgs_py.grid_tiles`); None: send the whole fuel."""


class StatusOut(NamedTuple):
    """An episode status (``phase`` ``waiting`` has tick -1)."""

    phase: str
    tick: int
    complete: bool = False


class ClockOut(NamedTuple):
    """Lockstep: sim time of the announced tick on ``/clock``."""

    stamp: int


class DiagnosticsOut(NamedTuple):
    """The node's episode status on ``/diagnostics`` (the node adds its input status)."""

    stamp: int
    status: NodeStatus


class LogOut(NamedTuple):
    text: str


Output = MapsOut | StatusOut | ClockOut | DiagnosticsOut | LogOut


class FireProtocol:
    """The episode clock and the acknowledgement barrier (see the module docstring)."""

    def __init__(
        self,
        episode: FireEpisode,
        mode: Mode,
        reporters: Iterable[str],
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.episode = episode
        self.mode = mode
        self.reporters = set(reporters)
        self.ready: set[str] = set()
        self.acked: dict[str, int] = {}
        self.started = False
        self.complete = False
        self.sent_fuel: np.ndarray | None = None
        self.fuel_steps = 0
        """Fire steps since the fuel went out whole."""
        self.clock = clock
        """Wall time in seconds, for the lockstep tick split (:mod:`wildfire_sim.tick_split`)."""
        self.split = TickSplit()

    def stamp_ns(self) -> int:
        """Sim time of the current tick."""
        return self.episode.decisions * DECISION_PERIOD_NS

    def start(self) -> list[Output]:
        """The initial grids and the waiting status."""
        return [self.maps(), StatusOut("waiting", -1)]

    def on_ack(self, reporter: str, stamp: int) -> list[Output]:
        """An acknowledgement (``reporter`` checked against :attr:`reporters`)."""
        if reporter.endswith(READY_SUFFIX):
            self.ready.add(reporter[: -len(READY_SUFFIX)])
        elif stamp > self.stamp_ns() or not self.started:
            # A tick not announced yet: acknowledging it would let the episode run on
            # without the reporter.
            raise RejectedMessage(DropReason.FUTURE, f"{reporter} acknowledged {stamp} ns")
        elif stamp <= self.acked.get(reporter, -1):
            raise RejectedMessage(DropReason.STALE, f"{reporter} acknowledged {stamp} ns again")
        else:
            self.acked[reporter] = stamp
            self.split.acked(reporter, self.clock())
        if not self.started:
            if self.reporters <= self.ready:
                self.started = True
                return [LogOut("every reporter is ready: tick 0"), *self.announce_tick()]
            return []
        return self.advance_lockstep() if self.mode is Mode.LOCKSTEP else []

    def advance_lockstep(self) -> list[Output]:
        """Next tick once every reporter has finished the current one."""
        out: list[Output] = []
        while not self.complete and all(
            self.acked.get(r, -1) >= self.stamp_ns() for r in self.reporters
        ):
            if self.episode.final:
                text = f"episode {self.episode.phase} after {self.episode.decisions} decisions"
                return out + self.finish(text)
            if self.episode.advance():
                out.append(self.maps())
            out += self.announce_tick()
        return out

    def on_timer(self) -> list[Output]:
        """Real time: one decision per 100 ms timer tick."""
        if not self.started or self.complete:
            return []
        if self.episode.final:
            return self.finish(f"episode {self.episode.phase} at {self.stamp_ns() / 1e9:.1f} s")
        if self.episode.advance():
            return [self.maps(), *self.announce_tick()]
        return self.announce_tick() if self.episode.final else []

    # --- outputs ------------------------------------------------------------------------------

    def maps(self) -> MapsOut:
        # Copies: the fire steps in place, maybe before these are sent.
        stamp, fuel = self.stamp_ns(), self.episode.fuel.copy()
        tiles = None
        if self.sent_fuel is not None and self.fuel_steps < WHOLE_EVERY_STEPS:
            tiles = changed_tiles(stamp, self.sent_fuel, fuel)
            self.fuel_steps += 1
        else:
            self.fuel_steps = 1
        self.sent_fuel = fuel
        return MapsOut(stamp, self.episode.burning.copy(), fuel, tiles)

    def announce_tick(self) -> list[Output]:
        """Status (phase, tick) then, in lockstep, the clock of the current tick."""
        out: list[Output] = [StatusOut(self.episode.phase, self.episode.decisions)]
        if self.mode is Mode.LOCKSTEP:
            self.split.announced(self.clock())
            out.append(ClockOut(self.stamp_ns()))
        if self.episode.decisions % STATUS_EVERY_TICKS == 0:
            out.append(self.diagnostics())
        return out

    def finish(self, text: str) -> list[Output]:
        self.complete = True
        if self.mode is Mode.LOCKSTEP:
            self.split.announced(self.clock())  # closes the last tick
        status = StatusOut(self.episode.phase, self.episode.decisions, complete=True)
        return [status, self.diagnostics(), LogOut(text)]

    def diagnostics(self) -> DiagnosticsOut:
        status = NodeStatus(
            f"{NAME}: episode",
            NAME,
            "OK",
            f"{self.episode.phase} at tick {self.episode.decisions}",
            {
                "tick": self.episode.decisions,
                "burning_cells": int(self.episode.burning.sum()),
                "complete": int(self.complete),
                **self.split.values(),
            },
        )
        return DiagnosticsOut(self.stamp_ns(), status)


__all__ = [
    "NAME",
    "ClockOut",
    "DiagnosticsOut",
    "FireProtocol",
    "LogOut",
    "MapsOut",
    "Output",
    "StatusOut",
]
