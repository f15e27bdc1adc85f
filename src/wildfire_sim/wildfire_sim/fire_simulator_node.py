"""Fire-simulator node: owns the true fire, publishes it, and paces the episode.

Publishes ``/wildfire/fire_map`` (latched) at the start and after every fire step, and
``/wildfire/fuel_map`` whole at the start and every 40 fire steps with the changed tiles on
``/wildfire/fuel_tiles`` between (:mod:`wildfire_msgs_py.grid_tiles`), and
``/wildfire/episode`` (phase, tick, scenario). Two modes:

* ``lockstep`` — drives ``/clock`` (tick ``k`` at ``k * 0.1`` s of sim time). It waits for
  ``<name>/ready`` on ``/wildfire/ack`` from every expected reporter (each agent ``uavK``,
  ``belief_aggregator`` and any ``extra_reporters``), then announces tick 0; tick ``k + 1``
  (with its fire step when due and its end check) is announced only once every reporter has
  acknowledged tick ``k``. The episode status of a tick is published before its clock.
* ``realtime`` — a 10 Hz wall-clock timer counts decisions; the fire steps every 2.5 s; the
  status is published at every fire step and at the end.

At the end the phase is ``terminated`` (fire at the border) or ``truncated`` (duration);
once every reporter has finished the last tick the status carries ``complete: true``.

The node only decodes, calls and encodes: the episode clock and the acknowledgement barrier
are :class:`wildfire_sim.fire_protocol.FireProtocol`. Acknowledgements from an unknown reporter,
of a tick not yet announced (future) or of one already acknowledged (a replay) are dropped
and counted in the node's ``/diagnostics`` input-validation status.
"""

from __future__ import annotations

import sys
from typing import Any

from wildfire_msgs_py import contract
from wildfire_msgs_py.codecs import (
    clock_to_msg,
    diagnostics_to_msg,
    fire_grid_to_msg,
    fuel_grid_to_msg,
)
from wildfire_msgs_py.grid_tiles import tile_to_msg
from wildfire_msgs_py.input_guard import InputGuard
from wildfire_msgs_py.system_codecs import episode_to_msg
from wildfire_msgs_py.wire_checks import checked_ack
from wildfire_ros.node_support import (
    ParamSpec,
    contract_publisher,
    contract_subscription,
    declare_parameters,
    run_node,
)
from wildfire_ros.runtime import Node
from wildfire_sim.episode import (
    DECISION_PERIOD_NS,
    EPISODE_DEFAULTS,
    MODES,
    FireEpisode,
    Mode,
    decisions_in,
)
from wildfire_sim.errors import FireConfigError
from wildfire_sim.fire_protocol import (
    NAME,
    ClockOut,
    DiagnosticsOut,
    FireProtocol,
    LogOut,
    MapsOut,
    Output,
    StatusOut,
)
from wildfire_sim.ground_parameters import GROUND_PARAMETERS, ground_of
from wildfire_sim.ground_wire import publish_ground
from wildfire_sim.shapes import Shape

D = EPISODE_DEFAULTS
PARAMETERS = (
    ParamSpec("seed", D.seed, "episode seed (fuel and fire randomness)", 0, 2**31 - 1),
    ParamSpec("shape", D.shape, "ignition shape", choices=tuple(s.value for s in Shape)),
    ParamSpec("wind_x", D.wind_x, "dimensionless wind towards east", -1.0, 1.0),
    ParamSpec("wind_y", D.wind_y, "dimensionless wind towards north", -1.0, 1.0),
    ParamSpec("duration_s", D.duration_s, "flight time limit in seconds", 0.1, 100_000.0),
    ParamSpec("preburn_steps", D.preburn_steps, "fire steps before the aircraft start", 0, 1000),
    ParamSpec(
        "preburn_area_m2",
        0.0,
        "with > 0, pre-burn until the fire has touched this area instead",
        0.0,
        4e8,
    ),
    *GROUND_PARAMETERS,
    ParamSpec("mode", "lockstep", "lockstep (sim time, /clock) or realtime", choices=MODES),
    ParamSpec("n_aircraft", 2, "aircraft uav0..uav{n-1} that report in lockstep", 1, 64),
    ParamSpec("extra_reporters", "", "comma-separated further lockstep reporters"),
    ParamSpec(
        "aggregator_reports",
        True,
        "the lockstep waits for the belief aggregator (false when the agents decide on their "
        "own replicas: the run then flies on without it)",
    ),
)


class FireSimulatorNode(Node):
    """Publishes the truth grids and runs the episode clock (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NAME, **kwargs)
        p = declare_parameters(self, PARAMETERS)
        mode = Mode(p["mode"])
        reporters = {f"uav{k}" for k in range(p["n_aircraft"])}
        if p["aggregator_reports"]:
            reporters.add("belief_aggregator")
        reporters |= {r.strip() for r in p["extra_reporters"].split(",") if r.strip()}
        self.scenario: dict[str, Any] = {
            "seed": p["seed"],
            "shape": p["shape"],
            "wind_x": p["wind_x"],
            "wind_y": p["wind_y"],
            "mode": mode.value,
            "n_aircraft": p["n_aircraft"],
            "map_rows": p["map_rows"],
            "map_cols": p["map_cols"],
        }
        episode = FireEpisode(
            p["seed"],
            p["shape"],
            (p["wind_x"], p["wind_y"]),
            max_decisions=decisions_in(p["duration_s"]),
            preburn_steps=p["preburn_steps"],
            border_cells=p["border_cells"],
            ground=ground_of(p),
            preburn_area_m2=p["preburn_area_m2"],
        )
        self.protocol = protocol = FireProtocol(episode, mode, reporters)
        self.input_guard = InputGuard(self.get_logger().warning)

        self.fire_pub = contract_publisher(self, contract.FIRE_MAP)
        self.fuel_pub = contract_publisher(self, contract.FUEL_MAP)
        self.fuel_tiles_pub = contract_publisher(self, contract.FUEL_TILES)
        self.ground_pub = publish_ground(self, p)  # rasters: what the other nodes wait for
        self.episode_pub = contract_publisher(self, contract.EPISODE)
        self.clock_pub = contract_publisher(self, contract.CLOCK)
        self.diagnostics_pub = contract_publisher(self, contract.DIAGNOSTICS)
        # Header is keyless: every reporter writes the same instance, so the reader keeps a
        # deep history or acknowledgements of different reporters would replace each other.
        contract_subscription(
            self,
            contract.ACK,
            lambda msg: self.publish(protocol.on_ack(*checked_ack(msg, protocol.reporters))),
            qos=contract.QosSpec(depth=1000, transient_local=True),
            guard=self.input_guard,
        )
        if mode is Mode.REALTIME:
            self.create_timer(DECISION_PERIOD_NS / 1e9, lambda: self.publish(protocol.on_timer()))
        self.publish(protocol.start())
        self.get_logger().info(
            f"{mode.value} episode seed {p['seed']} shape {p['shape']} wind "
            f"({p['wind_x']:+.3f}, {p['wind_y']:+.3f}); waiting for {sorted(reporters)}"
        )

    @property
    def episode(self) -> FireEpisode:
        return self.protocol.episode

    @property
    def complete(self) -> bool:
        """True once every reporter has finished the last tick."""
        return self.protocol.complete

    def publish(self, outputs: list[Output]) -> None:
        """Encode and publish the protocol's outputs, in their order."""
        for out in outputs:
            if isinstance(out, MapsOut):
                self.fire_pub.publish(fire_grid_to_msg(out.burning, out.stamp))
                if out.fuel_tiles is None:
                    self.fuel_pub.publish(fuel_grid_to_msg(out.fuel, out.stamp))
                for tile in out.fuel_tiles or ():
                    self.fuel_tiles_pub.publish(tile_to_msg(tile))
            elif isinstance(out, StatusOut):
                values = {
                    "tick": out.tick,
                    "time_s": max(out.tick, 0) * DECISION_PERIOD_NS / 1e9,
                    **self.scenario,
                    "complete": "true" if out.complete else "false",
                }
                self.episode_pub.publish(episode_to_msg(out.phase, values))
            elif isinstance(out, ClockOut):
                self.clock_pub.publish(clock_to_msg(out.stamp))
            elif isinstance(out, DiagnosticsOut):
                inputs = self.input_guard.status(NAME, NAME)
                message = diagnostics_to_msg([out.status, inputs], out.stamp)
                self.diagnostics_pub.publish(message)
            elif isinstance(out, LogOut):
                self.get_logger().info(out.text)


def main(args: list[str] | None = None) -> None:
    """``ros2 run wildfire_sim fire_simulator``."""
    sys.exit(run_node(FireSimulatorNode, NAME, args, (FireConfigError, ValueError)))


if __name__ == "__main__":
    main()
