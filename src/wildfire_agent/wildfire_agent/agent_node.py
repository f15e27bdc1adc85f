"""Agent node: one aircraft (namespace ``/uavK``), Dubins dynamics and its policy at 10 Hz.

Subscribes to the truth (``/wildfire/fire_map``), the episode status, every other aircraft's
``state_stamped``, and the shared belief with its exact ages; publishes ``odom``,
``bank_cmd``, ``action``, ``state``, ``state_stamped`` and ``visit`` in its namespace (under
camera sensing ``camera0/cells`` .. ``camera3/cells`` and ``camera/footprints`` instead of
``visit``), and its decision-deadline statistics on ``/diagnostics``. The decision itself is
:class:`wildfire_agent.aircraft_policy.AircraftPolicy`.

The node only decodes, calls and encodes: every input is checked
(:mod:`wildfire_msgs_py.wire_checks`) and handed to
:class:`wildfire_agent.agent_protocol.AgentProtocol`, which holds the lockstep barrier (the
environment's order of visit, decision, state and acknowledgement per tick), the real-time
100 ms slots and the deadline statistics; what it returns is published here. Messages the
checks or the protocol refuse (malformed, replays, stamps far ahead) are dropped and
counted in the node's ``/diagnostics`` (see ``docs/deployment.md``, "Security").

Every agent also keeps the last shared belief it saw and sends it on
``/wildfire/belief_snapshot`` when a restarted belief aggregator asks for it.
"""

from __future__ import annotations

import functools
import sys
import time
from typing import Any

from wildfire_agent.agent_parameters import PARAMETERS, agent_protocol
from wildfire_agent.agent_protocol import (
    MAX_BANK_RAD,
    AckOut,
    DeadlineOut,
    Mode,
    Output,
    RadioOut,
    StateOut,
)
from wildfire_agent.deadlines import PERIOD_S
from wildfire_agent.dynamics import MAX_BANK_STEPS, AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_msgs_py import camera_codec, codecs, contract, radio_codec, system_codecs
from wildfire_msgs_py.belief_inputs import belief_inputs
from wildfire_msgs_py.input_guard import InputGuard
from wildfire_msgs_py.wire_checks import (
    checked_episode,
    checked_fire_grid,
    checked_radio,
    checked_score,
    checked_stamped_state,
)
from wildfire_ros.node_support import (
    contract_publisher,
    contract_subscription,
    declare_parameters,
    run_node,
)
from wildfire_ros.runtime import Node
from wildfire_sim.ground_parameters import ground_of
from wildfire_sim.ground_wire import await_ground


class AgentNode(Node):
    """One aircraft (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("agent", **kwargs)
        p = declare_parameters(self, PARAMETERS)
        await_ground(self, p)  # rasters: the fire simulator's ground, before the protocol
        self.protocol = protocol = agent_protocol(p, lambda: self.get_clock().now().nanoseconds)
        self.k, self.seed, self.name_tag = protocol.k, p["seed"], protocol.name_tag
        self.input_guard = guard = InputGuard(self.get_logger().warning)

        def publisher(spec: contract.TopicSpec) -> Any:
            return contract_publisher(self, spec, self.k if spec.per_aircraft else None)

        self.odom_pub = publisher(contract.ODOM)
        self.bank_pub = publisher(contract.BANK_CMD)
        self.action_pub = publisher(contract.ACTION)
        self.state_pub = publisher(contract.STATE)
        self.stamped_pub = publisher(contract.STATE_STAMPED)
        # What the sensor reports: the visit window, or one window per camera.
        camera = protocol.sensor.sensor == "camera"
        self.report_specs = contract.report_topics(protocol.sensor.sensor)
        self.report_pubs = [publisher(spec) for spec in self.report_specs]
        self.footprint_pub = publisher(contract.CAMERA_FOOTPRINTS) if camera else None
        self.diagnostics_pub = publisher(contract.DIAGNOSTICS)
        self.ack_pub = publisher(contract.ACK)
        self.snapshot_pub = publisher(contract.BELIEF_SNAPSHOT)
        self.radio_pub = publisher(contract.RADIO) if protocol.radio is not None else None

        # Deep reader histories on the inputs lockstep waits for: a flood on a keyless topic
        # must not push the honest sample out of the queue before the executor takes it.
        deep = contract.QosSpec(depth=100, transient_local=True)
        geo = ground_of(p).geometry  # every map on the wire has the run's geometry
        inputs = [
            (contract.FIRE_MAP, lambda m: protocol.on_fire_map(*checked_fire_grid(m, geo))),
            (contract.EPISODE, lambda m: protocol.on_status(checked_episode(m, self.seed))),
        ]
        if protocol.keeps_belief:  # keyframes and deltas, mirrored into the belief of each tick
            inputs += belief_inputs(geo, protocol.on_belief_frame)
        subscriptions: list[tuple[contract.TopicSpec, Any, Any, int | None]] = [
            (spec, handle, deep, None) for spec, handle in inputs
        ]
        if protocol.keeps_belief:
            subscriptions += [
                (contract.SCORE, lambda m: protocol.on_score(checked_score(m)), None, None),
                (contract.BELIEF_REQUEST, self.belief_request_callback, None, None),
            ]
        for j in protocol.peer_states:
            subscriptions.append(
                (contract.STATE_STAMPED, functools.partial(self.peer_state, j), deep, j)
            )
            if protocol.radio is not None:
                subscriptions.append(
                    (contract.RADIO, functools.partial(self.peer_radio, j), deep, j)
                )
        for spec, handle, qos, peer in subscriptions:
            callback = functools.partial(self.deliver, handle)
            contract_subscription(self, spec, callback, aircraft=peer, qos=qos, guard=guard)
        self.publish(protocol.start())
        self.startup_timer = self.create_timer(0.1, self.startup_timer_callback)
        if protocol.mode is Mode.REALTIME:
            self.create_timer(PERIOD_S, lambda: self.publish(protocol.on_timer(time.monotonic())))
        self.get_logger().info(f"{self.name_tag}: policy {p['policy']} ({protocol.mode.value})")

    @property
    def state(self) -> AircraftState:
        """The aircraft's pose now."""
        return self.protocol.state

    def deliver(self, handler: Any, msg: Any) -> None:
        """Decode and hand ``msg`` to the protocol, then publish what it makes due."""
        self.publish(handler(msg))

    def peer_state(self, j: int, msg: Any) -> list[Output]:
        return self.protocol.on_peer_state(j, *checked_stamped_state(msg, MAX_BANK_RAD))

    def peer_radio(self, j: int, msg: Any) -> list[Output]:
        return self.protocol.on_radio(j, *checked_radio(msg, j, MAX_BANK_STEPS))

    def belief_request_callback(self, msg: Any) -> None:
        snapshot = self.protocol.on_belief_request(time.monotonic())
        if snapshot is not None:
            self.snapshot_pub.publish(system_codecs.snapshot_to_msg(snapshot))

    def startup_timer_callback(self) -> None:
        """Say ready once the aggregator listens to our reports (``AgentProtocol.on_startup``)."""
        topics = [spec.resolve(self.k) for spec in self.report_specs]
        if self.protocol.on_startup(all(self.count_subscribers(t) > 0 for t in topics)):
            tag = self.name_tag + system_codecs.READY_SUFFIX
            self.ack_pub.publish(system_codecs.ack_to_msg(tag, 0))
            self.destroy_timer(self.startup_timer)

    def publish(self, outputs: list[Output] | None) -> None:
        """Encode and publish the protocol's outputs, in their order."""
        for out in outputs or ():
            if isinstance(out, StateOut):
                if out.bank_rad is not None and out.action is not None:
                    self.bank_pub.publish(codecs.bank_cmd_to_msg(out.bank_rad))
                    self.action_pub.publish(codecs.action_to_msg(out.action))
                self.stamped_pub.publish(system_codecs.stamped_state_to_msg(out.vector, out.stamp))
                self.state_pub.publish(codecs.state_to_msg(out.vector))
                self.odom_pub.publish(codecs.pose_to_odometry(out.vector, self.k, out.stamp))
            elif isinstance(out, AckOut):
                self.ack_pub.publish(system_codecs.ack_to_msg(self.name_tag, out.stamp))
            elif isinstance(out, RadioOut):
                assert self.radio_pub is not None
                self.radio_pub.publish(radio_codec.radio_to_msg(out.message))
            elif isinstance(out, DeadlineOut):
                inputs = self.input_guard.status(f"{self.name_tag}/agent", self.name_tag)
                statuses = [out.status, inputs] + ([out.radio] if out.radio is not None else [])
                self.diagnostics_pub.publish(codecs.diagnostics_to_msg(statuses, out.stamp))
            else:
                for report_pub, window in zip(self.report_pubs, out.windows, strict=True):
                    report_pub.publish(codecs.visit_to_msg(window, out.stamp))
                if self.footprint_pub is not None:
                    message = camera_codec.footprints_to_msg(out.windows, self.k, out.stamp)
                    self.footprint_pub.publish(message)


def main(args: list[str] | None = None) -> None:
    """``ros2 run wildfire_agent agent --ros-args -r __ns:=/uav0 -p aircraft:=0``."""
    sys.exit(run_node(AgentNode, "agent", args, (AgentConfigError, ValueError)))


if __name__ == "__main__":
    main()
