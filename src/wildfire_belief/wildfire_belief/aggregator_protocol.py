"""The belief aggregator's protocol without ROS: decoded inputs in, what to publish out.

:class:`AggregatorProtocol` holds everything the aggregator node decides apart from
decoding and encoding, so the merge-when-all-visits-are-in barrier, the start and the
recovery of a restarted aggregator can be tested with plain calls
(``tests/test_aggregator_protocol.py``). Each ``on_*`` method takes one decoded, checked
input and returns the messages it makes due, in order (:data:`Output`); an input to drop
raises :class:`~wildfire_msgs_py.input_guard.RejectedMessage`.

* Lockstep: tick ``k >= 1`` is merged once the visit stamped ``k * 0.1 s`` of every
  aircraft is in (and the tick is announced); then the belief goes out stamped with the
  tick and the tick is acknowledged. Visits of a merged tick are replays.
* Real time: :meth:`AggregatorProtocol.on_timer` merges whatever visits arrived since the
  last timer tick.
* Ground station only (limited radio links): the agents decide on their own replicas, so
  the lockstep does not wait for the aggregator (``reports=False``: no acknowledgements);
  it merges and publishes as it goes, and the run flies on if it dies.
* Noisy sensing (``filtered``): the belief is the filtered one of every report
  (:class:`~wildfire_belief.filtered_aggregator.FilteredAggregator`), ``sources`` report
  windows per aircraft and tick (its cameras), and the score needs the truth: tick ``k`` is
  merged once the fire map of its fire step is in too. The belief goes out as the
  probability of burning.
* Restart: a real-time aggregator that starts into a running episode (status tick > 0)
  asks for the agents' copies and continues from the newest one, or from the ignition seed
  once ``recover_timeout_s`` passes without any.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from wildfire_belief.aggregator import BeliefAggregator
from wildfire_belief.filtered_aggregator import FilteredAggregator
from wildfire_msgs_py.codecs import NodeStatus, VisitWindow
from wildfire_msgs_py.input_guard import TickInbox, check_status_tick
from wildfire_msgs_py.system_codecs import READY_SUFFIX, BeliefSnapshot, EpisodeStatus
from wildfire_sim.episode import (
    AHEAD_TICKS,
    DECISION_PERIOD_NS,
    FIRE_STEP_NS,
    REALTIME_AHEAD_NS,
    Mode,
    fire_step_tick,
    stamp_ceiling_ns,
)

NAME = "belief_aggregator"
STATUS_EVERY_TICKS = 10
"""The node's status goes to ``/diagnostics`` once a second of flight."""


class BeliefOut(NamedTuple):
    """The shared belief, its ages and the score to publish, stamped."""

    stamp: int
    burning: np.ndarray
    age_s: np.ndarray
    score: float
    probability: np.ndarray | None
    """The probability of burning (noisy sensing); None under the perfect disc."""
    status: NodeStatus | None
    """The node's shared-belief status when due on ``/diagnostics`` (once a second)."""
    clock: int = 0
    """The belief's tick counter (its ages grow by one tick per tick of it)."""


class AckOut(NamedTuple):
    """An acknowledgement on ``/wildfire/ack`` (``reporter`` may carry the ready suffix)."""

    reporter: str
    stamp: int


class RequestOut(NamedTuple):
    """Ask the agents for their copy of the shared belief (``/wildfire/belief_request``)."""


class LogOut(NamedTuple):
    """A line for the node's log."""

    warning: bool
    text: str


Output = BeliefOut | AckOut | RequestOut | LogOut


class AggregatorProtocol:
    """Shared belief of ``n`` aircraft from their reports (see the module docstring).

    ``now_ns`` is the node clock (real-time stamps), ``clock`` a monotonic clock in seconds
    (the recovery timeout).
    """

    def __init__(
        self,
        n: int,
        mode: Mode,
        ignition: np.ndarray,
        now_ns: Callable[[], int],
        recover_timeout_s: float = 3.0,
        clock: Callable[[], float] = time.monotonic,
        reports: bool = True,
        filtered: FilteredAggregator | None = None,
        sources: int = 1,
    ) -> None:
        self.n = n
        self.reports = reports
        self.mode = mode
        self.filtered = filtered
        self.aggregator: BeliefAggregator | FilteredAggregator = filtered or BeliefAggregator(
            ignition
        )
        self.sources = sources
        self.fire: TickInbox[np.ndarray] = TickInbox(FIRE_STEP_NS)
        """Fire maps by stamp: the truth the score under noise needs."""
        self.now_ns = now_ns
        self.recover_timeout_s = recover_timeout_s
        self.clock = clock
        tick_ns = DECISION_PERIOD_NS if mode is Mode.LOCKSTEP else None
        # One inbox per report source: aircraft k's sensor c is source k * sources + c.
        self.visits: list[TickInbox[VisitWindow]] = [TickInbox(tick_ns) for _ in range(n * sources)]
        self.realtime_queue: list[tuple[int, VisitWindow]] = []
        self.status_tick = -1
        self.status_seen = False
        self.final = False
        self.ready_sent = False
        self.recovering_since: float | None = None
        self.snapshots: list[BeliefSnapshot] = []
        self.started = False
        self.scored = False

    def stamp(self, tick: int) -> int:
        """Stamp of tick ``tick`` in lockstep, the node clock in real time."""
        if self.mode is Mode.LOCKSTEP:
            return tick * DECISION_PERIOD_NS
        return self.now_ns()

    def published(self, stamp: int) -> list[Output]:
        """The belief to publish, and once, a line when the first cells score (from then on
        the ground station's score tells whether it is still merging)."""
        out: list[Output] = [self.belief(stamp)]
        if not self.scored and self.aggregator.score > 0:
            self.scored = True
            out.append(LogOut(False, f"first cells scored at tick {self.aggregator.ticks}"))
        return out

    def belief(self, stamp: int) -> BeliefOut:
        """The belief as it stands, with the node's status every ``STATUS_EVERY_TICKS``."""
        aggregator = self.aggregator
        status = None
        if aggregator.ticks % STATUS_EVERY_TICKS == 0:
            status = NodeStatus(
                f"{NAME}: shared belief",
                NAME,
                "OK",
                f"{aggregator.ticks} ticks merged",
                {
                    "ticks": aggregator.ticks,
                    "score": float(aggregator.score),
                    "believed_burning_cells": int(aggregator.burning.sum()),
                },
            )
        # A copy: the belief changes in place with the next merge, maybe before this is sent.
        burning = aggregator.burning.copy()
        probability = None if self.filtered is None else self.filtered.probability()
        score = float(aggregator.score)
        age_s = aggregator.age_s()
        return BeliefOut(stamp, burning, age_s, score, probability, status, aggregator.ticks)

    # --- inputs -------------------------------------------------------------------------------

    def on_startup(self, visits_matched: Callable[[], bool]) -> list[Output]:
        """Start once every agent's visit publisher is known (an orderly start: the visits
        themselves are durable, so none is lost to the order in which DDS matches endpoints).

        Not before the (latched) episode status is in: it tells a fresh start (waiting or
        tick 0) from a restart into a running episode, which first recovers the belief.
        """
        if self.started or not self.status_seen:
            return []
        out: list[Output] = []
        if self.recovering_since is not None:
            waited = self.clock() - self.recovering_since
            if not self.snapshots and waited < self.recover_timeout_s:
                return []
            out += self.finish_recovery()
        elif not visits_matched():
            return []
        self.started = True
        if not self.ready_sent:
            out.append(self.belief(self.stamp(0)))
            self.ready_sent = True
            out += self.ack(NAME + READY_SUFFIX, 0)
        return out + self.merge_lockstep()

    def on_status(self, status: EpisodeStatus) -> list[Output]:
        self.status_seen = True
        if status.phase == "waiting":
            return []
        lockstep = self.mode is Mode.LOCKSTEP
        check_status_tick(status.tick, self.status_tick, lockstep, AHEAD_TICKS)
        out: list[Output] = []
        # Only a real-time aggregator can be a restarted one (lockstep runs never respawn).
        restarted = not lockstep and not self.started and status.tick > 0
        if restarted and self.recovering_since is None:
            out += self.begin_recovery()
        self.status_tick = max(self.status_tick, status.tick)
        self.final = self.final or status.final
        if lockstep and self.started and status.tick == 0:
            out += self.ack(NAME, 0)
        return out + self.merge_lockstep()

    def on_visit(self, source: int, stamp: int, window: VisitWindow) -> list[Output]:
        """A report window of ``source`` (aircraft k's sensor c: ``k * sources + c``)."""
        inbox = self.visits[source]
        if self.mode is Mode.REALTIME:
            inbox.ceiling = self.now_ns() + REALTIME_AHEAD_NS
            inbox.accept(stamp, window)
            inbox.discard_below(stamp + 1)  # each visit is merged once: older stamps are replays
            self.realtime_queue.append((stamp, window))
            return []
        inbox.ceiling = stamp_ceiling_ns(self.status_tick)
        inbox.accept(stamp, window)
        return self.merge_lockstep()

    def on_fire_map(self, stamp: int, burning: np.ndarray) -> list[Output]:
        """The truth, for the score under noise (only a filtered aggregator listens)."""
        self.fire.ceiling = (
            stamp_ceiling_ns(self.status_tick)
            if self.mode is Mode.LOCKSTEP
            else self.now_ns() + REALTIME_AHEAD_NS
        )
        self.fire.accept(stamp, burning)
        if self.mode is Mode.REALTIME:
            self.fire.discard_below(stamp)  # score on the newest map
        return self.merge_lockstep()

    def on_snapshot(self, snapshot: BeliefSnapshot) -> None:
        if self.recovering_since is not None and not self.started:
            self.snapshots.append(snapshot)

    def on_timer(self) -> list[Output]:
        """Real time: one belief tick per 100 ms with the visits received meanwhile."""
        if not self.started:
            return []
        stamped, self.realtime_queue = self.realtime_queue, []
        if self.filtered is not None:
            # Every report is one more look (exact Bayes): the order does not matter.
            newest = self.fire.latest()
            truth = None if newest is None else newest[1]
            self.filtered.merge([window for _, window in stamped], truth)
        else:
            # Visits of different aircraft arrive in any order: none may undo a newer one.
            aggregator = self.aggregator
            assert isinstance(aggregator, BeliefAggregator)
            aggregator.merge(aggregator.fresher_visits(stamped))
        return self.published(self.stamp(0))

    # --- lockstep and recovery ----------------------------------------------------------------

    def merge_lockstep(self) -> list[Output]:
        """Merge every tick whose visits from all aircraft are in, in order."""
        out: list[Output] = []
        if self.mode is not Mode.LOCKSTEP or not self.started:
            return out
        while True:
            tick = self.aggregator.ticks + 1
            stamp = tick * DECISION_PERIOD_NS
            if tick > self.status_tick or any(stamp not in inbox for inbox in self.visits):
                return out
            windows = [inbox.items[stamp] for inbox in self.visits]
            if self.filtered is not None:
                truth = self.fire.get(fire_step_tick(tick) * DECISION_PERIOD_NS)
                if truth is None:
                    return out
                self.filtered.merge(windows, truth)
                self.fire.discard_below(fire_step_tick(tick) * DECISION_PERIOD_NS)
            else:
                self.aggregator.merge(windows)
            for inbox in self.visits:
                inbox.discard_below(stamp + DECISION_PERIOD_NS)
            out += [*self.published(stamp), *self.ack(NAME, stamp)]

    def ack(self, reporter: str, stamp: int) -> list[Output]:
        """An acknowledgement, if the lockstep waits for this aggregator."""
        return [AckOut(reporter, stamp)] if self.reports else []

    def begin_recovery(self) -> list[Output]:
        self.recovering_since = self.clock()
        text = "episode already running: asking the agents for the belief"
        return [LogOut(True, text), RequestOut()]

    def finish_recovery(self) -> list[Output]:
        if not self.snapshots:
            return [LogOut(True, "no belief copy received: starting from the ignition seed")]
        newest = max(self.snapshots, key=lambda s: s.time_s)
        self.aggregator.restore(newest.time_s, newest.score, newest.believed, newest.age_s)
        self.ready_sent = True
        text = f"recovered the shared belief of t = {newest.time_s:.1f} s, score {newest.score:.0f}"
        return [LogOut(False, text), self.belief(self.stamp(0))]


__all__ = [
    "NAME",
    "AckOut",
    "AggregatorProtocol",
    "BeliefOut",
    "LogOut",
    "Output",
    "RequestOut",
]
