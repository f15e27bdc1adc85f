"""Fire-simulator node: owns the true fire, publishes it, and paces the episode.

Publishes ``/wildfire/fire_map`` and ``/wildfire/fuel_map`` (latched) at the start and after
every fire step, and ``/wildfire/episode`` (phase, tick, scenario). Two modes:

* ``lockstep`` — drives ``/clock`` (tick ``k`` at ``k * 0.1`` s of sim time). It waits for
  ``<name>/ready`` on ``/wildfire/ack`` from every expected reporter (each agent ``uavK``,
  ``belief_aggregator`` and any ``extra_reporters``), then announces tick 0; tick ``k + 1``
  (with its fire step when due and its end check) is announced only once every reporter has
  acknowledged tick ``k``. The episode status of a tick is published before its clock.
* ``realtime`` — a 10 Hz wall-clock timer counts decisions; the fire steps every 2.5 s; the
  status is published at every fire step and at the end.

At the end the phase is ``terminated`` (fire at the border) or ``truncated`` (duration);
once every reporter has finished the last tick the status carries ``complete: true``.

Acknowledgements are checked before they count: an unknown reporter, a tick not yet
announced (future) or one already acknowledged (a replay) is dropped and counted in the
node's ``/diagnostics`` input-validation status.
"""

from __future__ import annotations

import sys
from typing import Any

from wildfire_msgs_py import contract
from wildfire_msgs_py.codecs import (
    NodeStatus,
    clock_to_msg,
    diagnostics_to_msg,
    fire_grid_to_msg,
    fuel_grid_to_msg,
)
from wildfire_msgs_py.input_guard import DropReason, InputGuard, RejectedMessage
from wildfire_msgs_py.node_support import (
    ParamSpec,
    contract_publisher,
    contract_subscription,
    declare_parameters,
    run_node,
)
from wildfire_msgs_py.runtime import Node
from wildfire_msgs_py.system_codecs import READY_SUFFIX, episode_to_msg
from wildfire_msgs_py.wire_checks import checked_ack
from wildfire_sim.episode import DECISION_PERIOD_NS, EPISODE_DEFAULTS, FireEpisode, decisions_in
from wildfire_sim.errors import FireConfigError
from wildfire_sim.shapes import Shape

MODES = ("lockstep", "realtime")
D = EPISODE_DEFAULTS
NAME = "fire_simulator"
STATUS_EVERY_TICKS = 10
"""The node's status goes to ``/diagnostics`` once a second of flight and at the end."""
PARAMETERS = (
    ParamSpec("seed", D.seed, "episode seed (fuel and fire randomness)", 0, 2**31 - 1),
    ParamSpec("shape", D.shape, "ignition shape", choices=tuple(s.value for s in Shape)),
    ParamSpec("wind_x", D.wind_x, "dimensionless wind towards east", -1.0, 1.0),
    ParamSpec("wind_y", D.wind_y, "dimensionless wind towards north", -1.0, 1.0),
    ParamSpec("duration_s", D.duration_s, "flight time limit in seconds", 0.1, 100_000.0),
    ParamSpec("preburn_steps", D.preburn_steps, "fire steps before the aircraft start", 0, 1000),
    ParamSpec(
        "border_cells",
        D.border_cells,
        "the episode ends when fire is this close to the edge",
        0,
        49,
    ),
    ParamSpec("mode", "lockstep", "lockstep (sim time, /clock) or realtime", choices=MODES),
    ParamSpec("n_aircraft", 2, "aircraft uav0..uav{n-1} that report in lockstep", 1, 64),
    ParamSpec("extra_reporters", "", "comma-separated further lockstep reporters"),
)


class FireSimulatorNode(Node):
    """Publishes the truth grids and runs the episode clock (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NAME, **kwargs)
        p = declare_parameters(self, PARAMETERS)
        self.mode: str = p["mode"]
        self.reporters: set[str] = {f"uav{k}" for k in range(p["n_aircraft"])}
        self.reporters.add("belief_aggregator")
        self.reporters |= {r.strip() for r in p["extra_reporters"].split(",") if r.strip()}
        self.scenario: dict[str, Any] = {
            "seed": p["seed"],
            "shape": p["shape"],
            "wind_x": p["wind_x"],
            "wind_y": p["wind_y"],
            "mode": self.mode,
            "n_aircraft": p["n_aircraft"],
        }
        self.episode = FireEpisode(
            p["seed"],
            p["shape"],
            (p["wind_x"], p["wind_y"]),
            max_decisions=decisions_in(p["duration_s"]),
            preburn_steps=p["preburn_steps"],
            border_cells=p["border_cells"],
        )
        self.ready: set[str] = set()
        self.acked: dict[str, int] = {}
        self.started = False
        self.complete = False
        self.input_guard = InputGuard(self.get_logger().warning)

        self.fire_pub = contract_publisher(self, contract.FIRE_MAP)
        self.fuel_pub = contract_publisher(self, contract.FUEL_MAP)
        self.episode_pub = contract_publisher(self, contract.EPISODE)
        self.clock_pub = contract_publisher(self, contract.CLOCK)
        self.diagnostics_pub = contract_publisher(self, contract.DIAGNOSTICS)
        # Header is keyless: every reporter writes the same instance, so the reader keeps a
        # deep history or acknowledgements of different reporters would replace each other.
        contract_subscription(
            self,
            contract.ACK,
            self.ack_callback,
            qos=contract.QosSpec(depth=1000, transient_local=True),
            guard=self.input_guard,
        )
        self.realtime_timer = (
            self.create_timer(DECISION_PERIOD_NS / 1e9, self.realtime_timer_callback)
            if self.mode == "realtime"
            else None
        )
        self.publish_maps()
        self.publish_status("waiting", tick=-1)
        self.get_logger().info(
            f"{self.mode} episode seed {p['seed']} shape {p['shape']} wind "
            f"({p['wind_x']:+.3f}, {p['wind_y']:+.3f}); waiting for {sorted(self.reporters)}"
        )

    # --- publishing ---------------------------------------------------------------------------

    def stamp_ns(self) -> int:
        """Sim time of the current tick."""
        return self.episode.decisions * DECISION_PERIOD_NS

    def publish_maps(self) -> None:
        stamp = self.stamp_ns()
        self.fire_pub.publish(fire_grid_to_msg(self.episode.burning, stamp))
        self.fuel_pub.publish(fuel_grid_to_msg(self.episode.fuel, stamp))

    def publish_status(self, phase: str, tick: int, complete: bool = False) -> None:
        values = {
            "tick": tick,
            "time_s": max(tick, 0) * DECISION_PERIOD_NS / 1e9,
            **self.scenario,
            "complete": "true" if complete else "false",
        }
        self.episode_pub.publish(episode_to_msg(phase, values))

    def announce_tick(self) -> None:
        """Status (phase, tick) then, in lockstep, the clock of the current tick."""
        self.publish_status(self.episode.phase, self.episode.decisions)
        if self.mode == "lockstep":
            self.clock_pub.publish(clock_to_msg(self.stamp_ns()))
        if self.episode.decisions % STATUS_EVERY_TICKS == 0:
            self.publish_diagnostics()

    def publish_diagnostics(self) -> None:
        """The node's status on ``/diagnostics`` (once a second of flight and at the end)."""
        status = NodeStatus(
            f"{NAME}: episode",
            NAME,
            "OK",
            f"{self.episode.phase} at tick {self.episode.decisions}",
            {
                "tick": self.episode.decisions,
                "burning_cells": int(self.episode.burning.sum()),
                "complete": int(self.complete),
            },
        )
        inputs = self.input_guard.status(NAME, NAME)
        self.diagnostics_pub.publish(diagnostics_to_msg([status, inputs], self.stamp_ns()))

    # --- callbacks ----------------------------------------------------------------------------

    def ack_callback(self, msg: Any) -> None:
        reporter, stamp = checked_ack(msg, self.reporters)
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
        if not self.started:
            if self.reporters <= self.ready:
                self.started = True
                self.get_logger().info("every reporter is ready: tick 0")
                self.announce_tick()
            return
        if self.mode == "lockstep":
            self.advance_lockstep()

    def advance_lockstep(self) -> None:
        """Next tick once every reporter has finished the current one."""
        stamp = self.stamp_ns()
        while not self.complete and all(self.acked.get(r, -1) >= stamp for r in self.reporters):
            if self.episode.final:
                self.complete = True
                self.publish_status(self.episode.phase, self.episode.decisions, complete=True)
                self.publish_diagnostics()
                self.get_logger().info(
                    f"episode {self.episode.phase} after {self.episode.decisions} decisions"
                )
                return
            if self.episode.advance():
                self.publish_maps()
            self.announce_tick()
            stamp = self.stamp_ns()

    def realtime_timer_callback(self) -> None:
        if not self.started or self.complete:
            return
        if self.episode.final:
            self.complete = True
            self.publish_status(self.episode.phase, self.episode.decisions, complete=True)
            self.publish_diagnostics()
            self.get_logger().info(f"episode {self.episode.phase} at {self.stamp_ns() / 1e9:.1f} s")
            return
        if self.episode.advance():
            self.publish_maps()
            self.announce_tick()
        elif self.episode.final:
            self.announce_tick()


def main(args: list[str] | None = None) -> None:
    """``ros2 run wildfire_sim fire_simulator``."""
    sys.exit(run_node(FireSimulatorNode, NAME, args, (FireConfigError, ValueError)))


if __name__ == "__main__":
    main()
