"""Belief-aggregator node: merges every aircraft's visits into the shared belief.

Subscribes to ``/uavK/visit`` of every aircraft and the episode status; publishes
``/wildfire/belief``, ``/wildfire/belief_age`` (display, 0..100) and
``/wildfire/belief_age_exact`` (float32 seconds, what belief policies see) whole once a fire
step (keyframes), ``/wildfire/belief_delta`` on the ticks between
(:mod:`wildfire_msgs_py.belief_delta`), and the cumulative ``/wildfire/score``, all latched.
The merge is :class:`wildfire_belief.aggregator.BeliefAggregator`; the belief starts as the
ignition seed (``wildfire_sim.ignition.ignite`` of the episode seed and shape).

The node only decodes, calls and encodes: the lockstep barrier (merge tick ``k`` once every
aircraft's visit of ``k`` is in), the real-time merges and the recovery of a restarted
aggregator (it asks the agents on ``/wildfire/belief_request`` and continues from the
newest ``/wildfire/belief_snapshot``) are
:class:`wildfire_belief.aggregator_protocol.AggregatorProtocol`.

Under noisy sensing (``sensor:=camera``, or a ``pixel_error``) the belief is the filtered
one (:class:`wildfire_belief.filtered_aggregator.FilteredAggregator`): it fuses the four
``/uavK/cameraC/cells`` windows of every aircraft (or its noisy ``visit``), scores against
``/wildfire/fire_map`` and publishes ``/wildfire/belief`` as the probability of burning.

Every visit is checked (size, values, frame, stamp) before it is kept: one per aircraft and
tick, the first one counts; replays of merged ticks, stamps far ahead and malformed windows
are dropped and counted in the node's ``/diagnostics`` input-validation status.
"""

from __future__ import annotations

import functools
import sys
import time
from typing import Any

from wildfire_belief.aggregator_parameters import PARAMETERS, aggregator_protocol
from wildfire_belief.aggregator_protocol import (
    NAME,
    AckOut,
    BeliefOut,
    LogOut,
    Output,
)
from wildfire_belief.sensors import report_window
from wildfire_msgs_py import contract
from wildfire_msgs_py.belief_codec import belief_grid
from wildfire_msgs_py.belief_delta import BeliefDelta, DeltaEncoder, delta_to_msg
from wildfire_msgs_py.codecs import belief_age_to_msg, diagnostics_to_msg, grid_to_msg, score_to_msg
from wildfire_msgs_py.input_guard import InputGuard
from wildfire_msgs_py.system_codecs import ack_to_msg, age_image_to_msg
from wildfire_msgs_py.wire_checks import (
    checked_episode,
    checked_fire_grid,
    checked_snapshot,
    checked_visit,
)
from wildfire_ros.node_support import (
    contract_publisher,
    contract_subscription,
    declare_parameters,
    run_node,
)
from wildfire_ros.runtime import Node
from wildfire_sim.episode import (
    DECISION_PERIOD_NS,
    Mode,
)
from wildfire_sim.errors import FireConfigError
from wildfire_sim.ground_parameters import ground_of
from wildfire_sim.ground_wire import await_ground


class BeliefAggregatorNode(Node):
    """Shared belief, its ages and the team score (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NAME, **kwargs)
        p = declare_parameters(self, PARAMETERS)
        await_ground(self, p)  # rasters: the fire simulator's ground, before the protocol
        self.n: int = p["n_aircraft"]
        self.seed: int = p["seed"]
        self.geometry = geometry = ground_of(p).geometry
        self.protocol = protocol = aggregator_protocol(
            p, lambda: self.get_clock().now().nanoseconds
        )
        mode, sensor = protocol.mode, p["sensor"]
        # Where the reports come from: the visit window, or one window per camera.
        self.report_specs = contract.report_topics(sensor)
        self.window_side = report_window(sensor)
        self.input_guard = InputGuard(self.get_logger().warning)

        self.belief_pub = contract_publisher(self, contract.BELIEF)
        self.age_pub = contract_publisher(self, contract.BELIEF_AGE)
        self.age_exact_pub = contract_publisher(self, contract.BELIEF_AGE_EXACT)
        self.delta_pub = contract_publisher(self, contract.BELIEF_DELTA)
        self.delta_encoder = DeltaEncoder()
        self.score_pub = contract_publisher(self, contract.SCORE)
        self.ack_pub = contract_publisher(self, contract.ACK)
        self.request_pub = contract_publisher(self, contract.BELIEF_REQUEST)
        self.diagnostics_pub = contract_publisher(self, contract.DIAGNOSTICS)
        # Deep, durable reader histories: visits (the writer keeps its last ten for a reader
        # that matches late), statuses and the snapshots of many agents on one keyless topic.
        latched = contract.QosSpec(depth=100, transient_local=True)
        for k in range(self.n):
            for c, spec in enumerate(self.report_specs):
                contract_subscription(
                    self,
                    spec,
                    functools.partial(self.visit_callback, k * protocol.sources + c),
                    aircraft=k,
                    qos=latched,
                    guard=self.input_guard,
                )
        if protocol.filtered is not None:  # the score under noise needs the truth
            contract_subscription(
                self,
                contract.FIRE_MAP,
                lambda msg: self.publish(protocol.on_fire_map(*checked_fire_grid(msg, geometry))),
                qos=latched,
                guard=self.input_guard,
            )
        contract_subscription(
            self,
            contract.EPISODE,
            lambda msg: self.publish(protocol.on_status(checked_episode(msg, self.seed))),
            qos=latched,
            guard=self.input_guard,
        )
        contract_subscription(
            self,
            contract.BELIEF_SNAPSHOT,
            lambda msg: protocol.on_snapshot(checked_snapshot(msg, geometry)),
            qos=latched,
            guard=self.input_guard,
        )
        self.startup_timer = self.create_timer(0.1, self.startup_timer_callback)
        if mode is Mode.REALTIME:
            self.create_timer(DECISION_PERIOD_NS / 1e9, lambda: self.publish(protocol.on_timer()))

    @property
    def aggregator(self) -> Any:
        """The merge state (:class:`wildfire_belief.aggregator.BeliefAggregator`)."""
        return self.protocol.aggregator

    def startup_timer_callback(self) -> None:
        def visits_matched() -> bool:
            return all(
                self.count_publishers(spec.resolve(k))
                for k in range(self.n)
                for spec in self.report_specs
            )

        self.publish(self.protocol.on_startup(visits_matched))
        if self.protocol.started:
            self.destroy_timer(self.startup_timer)
            topics = ", ".join(spec.resolve(k) for k in range(self.n) for spec in self.report_specs)
            self.get_logger().info(f"started: merging {topics}")

    def visit_callback(self, source: int, msg: Any) -> None:
        self.publish(
            self.protocol.on_visit(source, *checked_visit(msg, self.window_side, self.geometry))
        )

    def publish(self, outputs: list[Output]) -> None:
        """Encode and publish the protocol's outputs, in their order."""
        for out in outputs:
            if isinstance(out, BeliefOut):
                grid = belief_grid(out.burning, out.probability)
                frame = self.delta_encoder.encode(out.stamp, grid, out.age_s, out.clock)
                if isinstance(frame, BeliefDelta):
                    self.delta_pub.publish(delta_to_msg(frame))
                else:  # a keyframe: the whole maps
                    self.belief_pub.publish(grid_to_msg(grid, out.stamp))
                    self.age_pub.publish(belief_age_to_msg(out.age_s, out.stamp))
                    self.age_exact_pub.publish(age_image_to_msg(out.age_s, out.stamp))
                self.score_pub.publish(score_to_msg(out.score))
                if out.status is not None:
                    inputs = self.input_guard.status(NAME, NAME)
                    message = diagnostics_to_msg([out.status, inputs], out.stamp)
                    self.diagnostics_pub.publish(message)
            elif isinstance(out, AckOut):
                self.ack_pub.publish(ack_to_msg(out.reporter, out.stamp))
            elif isinstance(out, LogOut) and out.warning:
                # Two call sites: rclpy refuses one call site logging at two severities.
                self.get_logger().warning(out.text)
            elif isinstance(out, LogOut):
                self.get_logger().info(out.text)
            else:
                self.request_pub.publish(ack_to_msg(NAME, time.time_ns()))


def main(args: list[str] | None = None) -> None:
    """``ros2 run wildfire_belief belief_aggregator``."""
    sys.exit(run_node(BeliefAggregatorNode, NAME, args, (FireConfigError, ValueError)))


if __name__ == "__main__":
    main()
