"""Belief-aggregator node: merges every aircraft's visits into the shared belief.

Subscribes to ``/uavK/visit`` of every aircraft and the episode status; publishes
``/wildfire/belief``, ``/wildfire/belief_age`` (display, 0..100), ``/wildfire/belief_age_exact``
(float32 seconds, what belief policies see) and the cumulative ``/wildfire/score``, all
latched. The merge is :class:`wildfire_belief.aggregator.BeliefAggregator`; the belief starts
as the ignition seed (``wildfire_sim.episode.initial_fire`` of the episode seed and shape).

* Lockstep: for tick ``k >= 1`` it waits for the visit stamped ``k * 0.1 s`` of every
  aircraft, merges them (one ``tick`` of the belief clock), publishes the belief stamped with
  the tick and acknowledges the tick on ``/wildfire/ack``.
* Real time: a 10 Hz wall timer merges whatever visits arrived since the last tick.

Restart: when it starts while an episode is already running (the latched status has
``tick > 0``) it asks the agents for their copy of the shared belief on
``/wildfire/belief_request`` and continues from the newest ``/wildfire/belief_snapshot``
(within ``recover_timeout_s``; otherwise it warns and starts from the ignition seed).

Every visit is checked (size, values, frame, stamp) before it is kept: one per aircraft and
tick, the first one counts; replays of merged ticks, stamps far ahead and malformed windows
are dropped and counted in the node's ``/diagnostics`` input-validation status.
"""

from __future__ import annotations

import functools
import sys
import time
from typing import Any

from wildfire_belief.aggregator import BeliefAggregator
from wildfire_belief.visits import VISIT_WINDOW
from wildfire_msgs_py import contract
from wildfire_msgs_py.codecs import (
    NodeStatus,
    VisitWindow,
    belief_age_to_msg,
    belief_to_msg,
    diagnostics_to_msg,
    score_to_msg,
)
from wildfire_msgs_py.input_guard import InputGuard, TickInbox, check_status_tick
from wildfire_msgs_py.node_support import (
    ParamSpec,
    contract_publisher,
    contract_subscription,
    declare_parameters,
    run_node,
)
from wildfire_msgs_py.runtime import Node
from wildfire_msgs_py.system_codecs import READY_SUFFIX, ack_to_msg, age_image_to_msg
from wildfire_msgs_py.wire_checks import checked_episode, checked_snapshot, checked_visit
from wildfire_sim.episode import (
    DECISION_PERIOD_NS,
    DECISIONS_PER_FIRE_STEP,
    EPISODE_DEFAULTS,
    initial_fire,
)
from wildfire_sim.errors import FireConfigError
from wildfire_sim.shapes import Shape

NAME = "belief_aggregator"
STATUS_EVERY_TICKS = 10
"""The node's status goes to ``/diagnostics`` once a second of flight."""
AHEAD_TICKS = 2 * DECISIONS_PER_FIRE_STEP
"""Visits stamped further past the announced tick than this are refused (lockstep)."""
REALTIME_AHEAD_NS = 10_000_000_000
"""Real time: visits stamped more than 10 s past the node clock are refused."""
PARAMETERS = (
    ParamSpec("n_aircraft", 2, "aircraft uav0..uav{n-1} whose visits are merged", 1, 64),
    ParamSpec(
        "seed", EPISODE_DEFAULTS.seed, "episode seed (fixes the ignition seed's fuel)", 0, 2**31 - 1
    ),
    ParamSpec(
        "shape", EPISODE_DEFAULTS.shape, "ignition shape", choices=tuple(s.value for s in Shape)
    ),
    ParamSpec(
        "mode", "lockstep", "lockstep (sim time) or realtime", choices=("lockstep", "realtime")
    ),
    ParamSpec(
        "recover_timeout_s", 3.0, "how long a restarted aggregator waits for a copy", 0.0, 60.0
    ),
)


class BeliefAggregatorNode(Node):
    """Shared belief, its ages and the team score (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NAME, **kwargs)
        p = declare_parameters(self, PARAMETERS)
        self.n: int = p["n_aircraft"]
        self.mode: str = p["mode"]
        self.seed: int = p["seed"]
        self.recover_timeout_s: float = p["recover_timeout_s"]
        ignition = initial_fire(p["seed"], p["shape"]).burning[0]
        self.aggregator = BeliefAggregator(ignition)
        tick_ns = DECISION_PERIOD_NS if self.mode == "lockstep" else None
        self.visits: list[TickInbox[VisitWindow]] = [TickInbox(tick_ns) for _ in range(self.n)]
        self.realtime_queue: list[VisitWindow] = []
        self.input_guard = InputGuard(self.get_logger().warning)
        self.status_tick = -1
        self.status_seen = False
        self.final = False
        self.ready_sent = False
        self.recovering_since: float | None = None
        self.snapshots: list[Any] = []
        self.started = False

        self.belief_pub = contract_publisher(self, contract.BELIEF)
        self.age_pub = contract_publisher(self, contract.BELIEF_AGE)
        self.age_exact_pub = contract_publisher(self, contract.BELIEF_AGE_EXACT)
        self.score_pub = contract_publisher(self, contract.SCORE)
        self.ack_pub = contract_publisher(self, contract.ACK)
        self.request_pub = contract_publisher(self, contract.BELIEF_REQUEST)
        self.diagnostics_pub = contract_publisher(self, contract.DIAGNOSTICS)
        for k in range(self.n):
            contract_subscription(
                self,
                contract.VISIT,
                functools.partial(self.visit_callback, k),
                aircraft=k,
                qos=contract.QosSpec(depth=100),
                guard=self.input_guard,
            )
        contract_subscription(
            self,
            contract.EPISODE,
            self.episode_callback,
            qos=contract.QosSpec(depth=100, transient_local=True),
            guard=self.input_guard,
        )
        # Many agents answer on one keyless topic: keep them all.
        contract_subscription(
            self,
            contract.BELIEF_SNAPSHOT,
            self.snapshot_callback,
            qos=contract.QosSpec(depth=100, transient_local=True),
            guard=self.input_guard,
        )
        self.startup_timer = self.create_timer(0.1, self.startup_timer_callback)
        self.merge_timer = (
            self.create_timer(DECISION_PERIOD_NS / 1e9, self.merge_timer_callback)
            if self.mode == "realtime"
            else None
        )

    # --- publishing ---------------------------------------------------------------------------

    def publish_belief(self, stamp: int) -> None:
        ages = self.aggregator.age_s()
        self.belief_pub.publish(belief_to_msg(self.aggregator.burning, stamp))
        self.age_pub.publish(belief_age_to_msg(ages, stamp))
        self.age_exact_pub.publish(age_image_to_msg(ages, stamp))
        self.score_pub.publish(score_to_msg(float(self.aggregator.score)))
        if self.aggregator.ticks % STATUS_EVERY_TICKS == 0:
            status = NodeStatus(
                f"{NAME}: shared belief",
                NAME,
                "OK",
                f"{self.aggregator.ticks} ticks merged",
                {
                    "ticks": self.aggregator.ticks,
                    "score": float(self.aggregator.score),
                    "believed_burning_cells": int(self.aggregator.burning.sum()),
                },
            )
            inputs = self.input_guard.status(NAME, NAME)
            self.diagnostics_pub.publish(diagnostics_to_msg([status, inputs], stamp))

    def stamp(self, tick: int) -> int:
        if self.mode == "lockstep":
            return tick * DECISION_PERIOD_NS
        return self.get_clock().now().nanoseconds

    # --- callbacks ----------------------------------------------------------------------------

    def startup_timer_callback(self) -> None:
        """Start once every agent's visit publisher is matched (visits are volatile).

        Not before the (latched) episode status is in: it tells a fresh start (waiting or
        tick 0) from a restart into a running episode, which first recovers the belief.
        """
        if self.started or not self.status_seen:
            return
        if self.recovering_since is not None:
            waited = time.monotonic() - self.recovering_since
            if not self.snapshots and waited < self.recover_timeout_s:
                return
            self.finish_recovery()
        elif any(self.count_publishers(contract.VISIT.resolve(k)) < 1 for k in range(self.n)):
            return
        self.started = True
        if not self.ready_sent:
            self.publish_belief(self.stamp(0))
            self.ready_sent = True
            self.ack_pub.publish(ack_to_msg(NAME + READY_SUFFIX, 0))
        self.destroy_timer(self.startup_timer)
        self.merge_lockstep()

    def episode_callback(self, msg: Any) -> None:
        status = checked_episode(msg, self.seed)
        self.status_seen = True
        if status.phase == "waiting":
            return
        check_status_tick(status.tick, self.status_tick, self.mode == "lockstep", AHEAD_TICKS)
        # Only a real-time aggregator can be a restarted one (lockstep runs never respawn).
        restarted = self.mode == "realtime" and not self.started and status.tick > 0
        if restarted and self.recovering_since is None:
            self.begin_recovery()
        self.status_tick = max(self.status_tick, status.tick)
        self.final = self.final or status.final
        if self.mode == "lockstep" and self.started and status.tick == 0:
            self.ack_pub.publish(ack_to_msg(NAME, 0))
        self.merge_lockstep()

    def visit_callback(self, k: int, msg: Any) -> None:
        stamp, window = checked_visit(msg, VISIT_WINDOW)
        inbox = self.visits[k]
        if self.mode == "realtime":
            inbox.ceiling = self.get_clock().now().nanoseconds + REALTIME_AHEAD_NS
            inbox.accept(stamp, window)
            inbox.discard_below(stamp + 1)  # each visit is merged once: older stamps are replays
            self.realtime_queue.append(window)
            return
        inbox.ceiling = (max(self.status_tick, 0) + AHEAD_TICKS) * DECISION_PERIOD_NS
        inbox.accept(stamp, window)
        self.merge_lockstep()

    def snapshot_callback(self, msg: Any) -> None:
        snapshot = checked_snapshot(msg)
        if self.recovering_since is not None and not self.started:
            self.snapshots.append(snapshot)

    def merge_timer_callback(self) -> None:
        """Real time: one belief tick per 100 ms with the visits received meanwhile."""
        if not self.started:
            return
        windows, self.realtime_queue = self.realtime_queue, []
        self.aggregator.merge(windows)
        self.publish_belief(self.stamp(0))

    # --- lockstep and recovery ----------------------------------------------------------------

    def merge_lockstep(self) -> None:
        """Merge every tick whose visits from all aircraft are in, in order."""
        if self.mode != "lockstep" or not self.started:
            return
        while True:
            tick = self.aggregator.ticks + 1
            stamp = tick * DECISION_PERIOD_NS
            if tick > self.status_tick or any(stamp not in inbox for inbox in self.visits):
                return
            windows = [inbox.items[stamp] for inbox in self.visits]
            for inbox in self.visits:
                inbox.discard_below(stamp + DECISION_PERIOD_NS)
            self.aggregator.merge(windows)
            self.publish_belief(stamp)
            self.ack_pub.publish(ack_to_msg(NAME, stamp))

    def begin_recovery(self) -> None:
        self.get_logger().warning("episode already running: asking the agents for the belief")
        self.recovering_since = time.monotonic()
        self.request_pub.publish(ack_to_msg(NAME, time.time_ns()))

    def finish_recovery(self) -> None:
        if not self.snapshots:
            self.get_logger().warning("no belief copy received: starting from the ignition seed")
            return
        newest = max(self.snapshots, key=lambda s: s.time_s)
        self.aggregator.restore(newest.time_s, newest.score, newest.believed, newest.age_s)
        self.get_logger().info(
            f"recovered the shared belief of t = {newest.time_s:.1f} s, score {newest.score:.0f}"
        )
        self.publish_belief(self.stamp(0))
        self.ready_sent = True


def main(args: list[str] | None = None) -> None:
    """``ros2 run wildfire_belief belief_aggregator``."""
    sys.exit(run_node(BeliefAggregatorNode, NAME, args, (FireConfigError, ValueError)))


if __name__ == "__main__":
    main()
