"""Live view node: serves the running system to Foxglove over its WebSocket protocol.

Feeds the fire map, every tick's belief and ages (mirrored from the belief's keyframes and
deltas, checked against ``map_rows`` x ``map_cols``), every aircraft's odometry and camera
footprints and the score to :class:`~wildfire_bringup.live_view.LiveView`, on a foxglove-sdk
WebSocket server bound to 127.0.0.1 (``port``, 8765 by default). Open Foxglove, "Open
connection", ``ws://localhost:8765``, and import the shipped layout
``docs/foxglove/wildfire.json``.

It is an observer only: it acknowledges nothing, so in lockstep the fire simulator never
waits for it, and a run flies on if it dies. It subscribes to a topic only while a client
watches a channel that topic feeds (checked every :data:`WATCH_PERIOD_S` of wall time), so
with no client connected it receives nothing and costs the run nothing. ``wildfire run
--foxglove`` starts it as one more process of the system; ``ros2 run wildfire_bringup
live_view`` starts it beside any running system.
"""

from __future__ import annotations

import functools
import sys
from typing import Any

from wildfire_bringup.live_view import DEFAULT_PORT, HOST, LiveView
from wildfire_msgs_py import contract
from wildfire_msgs_py.belief_inputs import belief_inputs
from wildfire_msgs_py.input_guard import InputGuard
from wildfire_msgs_py.map_geometry import MapGeometry
from wildfire_msgs_py.wire_checks import checked_score
from wildfire_ros.node_support import (
    ParamSpec,
    contract_subscription,
    declare_parameters,
    run_node,
)
from wildfire_ros.runtime import Node
from wildfire_sim.ground_parameters import GROUND_PARAMETERS

NAME = "live_view"
WATCH_PERIOD_S = 0.2
"""How often the subscriptions are matched to what the clients watch. Wall time: in lockstep
sim time races or stands still, and a viewer is served either way."""

PARAMETERS = (
    ParamSpec("port", DEFAULT_PORT, f"WebSocket port on {HOST} (Foxglove's default)", 1, 65535),
    ParamSpec("n_aircraft", 2, "aircraft uav0..uav{n-1} to show", 1, 64),
    *(spec for spec in GROUND_PARAMETERS if spec.name in ("map_rows", "map_cols")),
)

Feed = tuple[contract.TopicSpec, "int | None"]
"""One subscription the view may need: a topic of the contract, and the aircraft for a
per-aircraft topic."""


class LiveViewError(RuntimeError):
    """The server could not start (the port is taken)."""


class LiveViewNode(Node):
    """Feeds the watched topics of the run to a Foxglove WebSocket server."""

    def __init__(self, view: LiveView | None = None) -> None:
        super().__init__(NAME)
        p = declare_parameters(self, PARAMETERS)
        self.port: int = p["port"]
        self.n_aircraft: int = p["n_aircraft"]
        self.view = view or LiveView()
        try:
            self.server = self.view.start_server(self.port)
        except RuntimeError as error:
            raise LiveViewError(f"port {self.port} on {HOST}: {error}") from None
        # Any participant may publish anything: a malformed message is dropped and counted.
        self.input_guard = InputGuard(self.get_logger().warning)
        self.feeds: dict[Feed, Any] = {
            (contract.FIRE_MAP, None): functools.partial(self.map_callback, contract.FIRE_MAP.name)
        }
        geometry = MapGeometry(p["map_rows"], p["map_cols"])  # what the belief inputs must fit
        for spec, handler in belief_inputs(geometry, lambda f: [self.view.belief_frame(f)]):
            self.feeds[(spec, None)] = handler
        self.feeds[(contract.SCORE, None)] = self.score_callback
        for k in range(self.n_aircraft):
            self.feeds[(contract.ODOM, k)] = functools.partial(self.odom_callback, k)
            self.feeds[(contract.CAMERA_FOOTPRINTS, k)] = functools.partial(
                self.footprints_callback, k
            )
        self.subscribed: dict[Feed, Any] = {}
        """The feeds subscribed to now, and their subscriptions."""
        self.watch_timer = self.create_timer(WATCH_PERIOD_S, self.watch_callback)
        self.get_logger().info(
            f"Foxglove live view on ws://{HOST}:{self.server.port} ({self.n_aircraft} aircraft)"
        )

    # --- callbacks ----------------------------------------------------------------------------

    def watch_callback(self) -> None:
        """Subscribe to the topics a client now watches; drop those no client watches."""
        wanted = self.view.wanted()
        for feed, callback in self.feeds.items():
            spec, k = feed
            subscription = self.subscribed.get(feed)
            if spec.name in wanted and subscription is None:
                # An observer keeps the latest only: what it misses while busy it never needed.
                # The maps and the score are latched: a new subscription gets the latest now.
                qos = contract.QosSpec(depth=1, transient_local=spec.qos.transient_local)
                self.subscribed[feed] = contract_subscription(
                    self, spec, callback, aircraft=k, qos=qos, guard=self.input_guard
                )
            elif spec.name not in wanted and subscription is not None:
                self.destroy_subscription(subscription)
                del self.subscribed[feed]

    def map_callback(self, topic: str, msg: Any) -> None:
        self.view.grid(topic, msg)

    def odom_callback(self, k: int, msg: Any) -> None:
        self.view.odometry(k, msg)

    def footprints_callback(self, k: int, msg: Any) -> None:
        self.view.camera_footprints(k, msg)

    def score_callback(self, msg: Any) -> None:
        self.view.score(checked_score(msg))

    def destroy_node(self) -> None:
        """Stop the server (clients see it close) and unadvertise, then the node."""
        self.server.stop()
        self.view.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """``ros2 run wildfire_bringup live_view``."""
    sys.exit(run_node(LiveViewNode, NAME, args, (LiveViewError,)))


if __name__ == "__main__":
    main()
