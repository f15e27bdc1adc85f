"""Run monitor: the launcher's own node, watching the system it started.

It collects what the summary and the picture need — every aircraft's exact trajectory
(``state_stamped``), the final truth (fire and fuel maps), every cell that burned on any fire
map (for the score ceiling), the shared belief and its exact ages, the score, each agent's
deadline statistics and the episode status. In lockstep it is a reporter too
(``wildfire_run``): it acknowledges tick ``k`` once it holds every aircraft's ``s_{k+1}``, so
the recorder spinning in the same process never falls behind the system.

In lockstep (``union_score``) the monitor also merges every aircraft's visits itself, with
the aggregator's own functions, and its score, belief and ages are those of the union of
visits (what ``wildfire eval`` scores), acknowledging a tick only once that tick's visits are
merged too. So the run's score never waits on the aggregator's last messages, which travel
on other topics than the end of the episode and may come late on a loaded machine; and
under limited radio links, where no decision depends on the aggregator, it may die
mid-run. With ``radio`` it also counts the bytes of every radio message as serialized on
the wire (raw subscriptions: the CDR payload each reader receives), for the radio
bandwidth per aircraft.

Under noisy sensing (``sensor`` camera or a ``pixel_error``) the union is the filtered
belief of every report (:class:`~wildfire_belief.filtered_aggregator.FilteredAggregator`,
the aggregator's and the environment's rules), scored against the fire map of each tick.

Like every node it checks what it receives (:mod:`wildfire_msgs_py.wire_checks`), so the
summary is built from the system's own messages; the dropped ones are counted. What it keeps
and when it acknowledges is :class:`~wildfire_bringup.monitor_protocol.RunMonitor` (no ROS);
this node decodes, hands over and publishes the acknowledgements.
"""

from __future__ import annotations

import functools
from typing import Any

from wildfire_agent.agent_protocol import MAX_BANK_RAD
from wildfire_bringup.monitor_protocol import REPORTER, RunMonitor
from wildfire_msgs_py import contract
from wildfire_msgs_py.belief_inputs import belief_inputs
from wildfire_msgs_py.codecs import diagnostics_from_msg
from wildfire_msgs_py.input_guard import InputGuard
from wildfire_msgs_py.system_codecs import READY_SUFFIX, ack_to_msg
from wildfire_msgs_py.wire_checks import (
    checked_episode,
    checked_fire_grid,
    checked_fuel_grid,
    checked_fuel_tile,
    checked_score,
    checked_stamped_state,
    checked_visit,
)
from wildfire_ros.node_support import contract_publisher, contract_subscription
from wildfire_ros.runtime import Node, get_message, qos_profile
from wildfire_sim.episode import EPISODE_DEFAULTS
from wildfire_sim.landscape import PAPER_LANDSCAPE, Landscape


class RunMonitorNode(Node, RunMonitor):
    """Collects trajectories and final maps; lockstep reporter ``wildfire_run``."""

    def __init__(
        self,
        n_aircraft: int,
        lockstep: bool,
        seed: int,
        union_score: bool = False,
        shape: str = "circular",
        radio: bool = False,
        sensor: str = "disc",
        pixel_error: float = 0.0,
        preburn_steps: int = EPISODE_DEFAULTS.preburn_steps,
        wind_filter: bool = False,
        ground: Landscape = PAPER_LANDSCAPE,
        border_cells: int = EPISODE_DEFAULTS.border_cells,
    ) -> None:
        Node.__init__(self, REPORTER)
        guard = InputGuard(self.get_logger().warning)
        RunMonitor.__init__(
            self, n_aircraft, lockstep, seed, guard, union_score, shape, sensor, pixel_error,
            preburn_steps, wind_filter, ground, border_cells,
        )  # fmt: skip
        geometry = self.geometry
        self.ack_pub = contract_publisher(self, contract.ACK)

        def subscribe(spec: contract.TopicSpec, handle: Any, aircraft: int | None = None) -> None:
            # The monitor records every message: a deep history on every topic.
            qos = contract.QosSpec(depth=100, transient_local=spec.qos.transient_local)
            callback = functools.partial(self.deliver, handle)
            contract_subscription(self, spec, callback, aircraft=aircraft, qos=qos, guard=guard)

        subscribe(contract.EPISODE, lambda m: self.on_episode(checked_episode(m, self.seed)))
        subscribe(contract.FIRE_MAP, lambda m: self.on_fire_map(*checked_fire_grid(m, geometry)))
        subscribe(contract.FUEL_MAP, lambda m: self.on_fuel_map(*checked_fuel_grid(m, geometry)))
        subscribe(contract.FUEL_TILES, lambda m: self.on_fuel_tile(checked_fuel_tile(m, geometry)))
        for spec, handle in belief_inputs(geometry, self.on_belief_frame):
            subscribe(spec, handle)
        subscribe(contract.SCORE, lambda m: self.on_score(checked_score(m)))
        for k in range(n_aircraft):
            subscribe(contract.STATE_STAMPED, functools.partial(self.state_callback, k), k)
        report_specs = contract.report_topics(sensor)
        for k in range(n_aircraft if union_score else 0):
            for c, spec in enumerate(report_specs):
                subscribe(spec, functools.partial(self.visit_callback, k * self.sources + c), k)
        for k in range(n_aircraft if radio else 0):
            # Raw: the CDR payload each reader receives, for the bandwidth per aircraft.
            self.create_subscription(
                get_message(contract.RADIO.type),
                contract.RADIO.resolve(k),
                functools.partial(self.radio_callback, k),
                qos_profile(contract.QosSpec(depth=100, transient_local=True)),
                raw=True,
            )
        subscribe(contract.DIAGNOSTICS, lambda m: self.on_diagnostics(diagnostics_from_msg(m)))
        self.ack_pub.publish(ack_to_msg(REPORTER + READY_SUFFIX, 0))

    def deliver(self, handle: Any, msg: Any) -> None:
        """Decode and hand ``msg`` over, then acknowledge the ticks it completed."""
        for stamp in handle(msg) or ():
            self.ack_pub.publish(ack_to_msg(REPORTER, stamp))

    def state_callback(self, k: int, msg: Any) -> list[int]:
        return self.on_state(k, *checked_stamped_state(msg, MAX_BANK_RAD))

    def radio_callback(self, k: int, data: bytes) -> None:
        self.on_radio(k, len(data))

    def visit_callback(self, source: int, msg: Any) -> list[int]:
        return self.on_visit(source, *checked_visit(msg, self.report_side, self.geometry))


__all__ = ["REPORTER", "RunMonitorNode"]
