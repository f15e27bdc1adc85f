"""Run monitor: the launcher's own node, watching the system it started.

It collects what the summary and the picture need — every aircraft's exact trajectory
(``state_stamped``), the final truth (fire and fuel maps), every cell that burned on any fire
map (for the score ceiling), the shared belief and its exact ages, the score, each agent's
deadline statistics and the episode status. In lockstep it is a reporter too
(``wildfire_run``): it acknowledges tick ``k`` once it holds every aircraft's ``s_{k+1}``, so
the recorder spinning in the same process never falls behind the system.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from wildfire_msgs_py import contract
from wildfire_msgs_py.codecs import (
    belief_from_msg,
    diagnostics_from_msg,
    fire_grid_from_msg,
    fuel_grid_from_msg,
    score_from_msg,
    time_from_msg,
)
from wildfire_msgs_py.node_support import contract_publisher, contract_subscription
from wildfire_msgs_py.runtime import Node
from wildfire_msgs_py.system_codecs import (
    READY_SUFFIX,
    EpisodeStatus,
    ack_to_msg,
    age_image_from_msg,
    episode_from_msg,
    stamped_state_from_msg,
)

REPORTER = "wildfire_run"
TICK_NS = 100_000_000


class RunMonitorNode(Node):
    """Collects trajectories and final maps; lockstep reporter ``wildfire_run``."""

    def __init__(self, n_aircraft: int, lockstep: bool) -> None:
        super().__init__("wildfire_run")
        self.n = n_aircraft
        self.lockstep = lockstep
        self.states: list[dict[int, np.ndarray]] = [{} for _ in range(n_aircraft)]
        self.status: EpisodeStatus | None = None
        self.fire: np.ndarray | None = None
        self.burned: np.ndarray | None = None
        self.fuel: np.ndarray | None = None
        self.belief: np.ndarray | None = None
        self.belief_stamp = -1
        self.ages: np.ndarray | None = None
        self.score = 0.0
        self.deadlines: dict[int, dict[str, float]] = {}
        self.acked_tick = -1
        self.ack_pub = contract_publisher(self, contract.ACK)

        def subscribe(spec: contract.TopicSpec, callback: Any, aircraft: int | None = None) -> None:
            # The monitor records every message: a deep history on every topic.
            qos = contract.QosSpec(depth=100, transient_local=spec.qos.transient_local)
            contract_subscription(self, spec, callback, aircraft=aircraft, qos=qos)

        subscribe(contract.EPISODE, self.episode_callback)
        subscribe(contract.FIRE_MAP, self.fire_map_callback)
        subscribe(contract.FUEL_MAP, self.fuel_map_callback)
        subscribe(contract.BELIEF, self.belief_callback)
        subscribe(contract.BELIEF_AGE_EXACT, self.belief_age_callback)
        subscribe(contract.SCORE, self.score_callback)
        for k in range(n_aircraft):
            subscribe(contract.STATE_STAMPED, lambda msg, k=k: self.state_callback(k, msg), k)
        subscribe(contract.DIAGNOSTICS, self.diagnostics_callback)
        self.ack_pub.publish(ack_to_msg(REPORTER + READY_SUFFIX, 0))

    # --- callbacks ----------------------------------------------------------------------------

    def episode_callback(self, msg: Any) -> None:
        status = episode_from_msg(msg)
        if self.status is None or status.tick >= self.status.tick:
            self.status = status
        self.report()

    def fire_map_callback(self, msg: Any) -> None:
        self.fire = fire_grid_from_msg(msg)
        self.burned = self.fire.copy() if self.burned is None else self.burned | self.fire

    def fuel_map_callback(self, msg: Any) -> None:
        self.fuel = fuel_grid_from_msg(msg)

    def belief_callback(self, msg: Any) -> None:
        self.belief = belief_from_msg(msg)
        self.belief_stamp = time_from_msg(msg.header.stamp)

    def belief_age_callback(self, msg: Any) -> None:
        self.ages = age_image_from_msg(msg)

    def score_callback(self, msg: Any) -> None:
        self.score = score_from_msg(msg)

    def state_callback(self, k: int, msg: Any) -> None:
        stamp, vector = stamped_state_from_msg(msg)
        self.states[k][stamp] = vector
        self.report()

    def diagnostics_callback(self, msg: Any) -> None:
        """Keep every agent's latest decision-deadline statistics."""
        for status in diagnostics_from_msg(msg):
            k = contract.aircraft_index("/" + status.hardware_id)
            if k is not None and status.name.endswith(contract.DEADLINE_STATUS):
                self.deadlines[k] = {
                    key: value for key, value in status.values.items() if isinstance(value, float)
                }

    # --- lockstep -----------------------------------------------------------------------------

    def report(self) -> None:
        """Acknowledge every announced tick whose next states are all in."""
        if not self.lockstep or self.status is None or self.status.phase == "waiting":
            return
        while self.acked_tick < self.status.tick:
            tick = self.acked_tick + 1
            final = self.status.final and tick >= self.status.tick
            if not final and any((tick + 1) * TICK_NS not in s for s in self.states):
                return
            self.acked_tick = tick
            self.ack_pub.publish(ack_to_msg(REPORTER, tick * TICK_NS))

    # --- results ------------------------------------------------------------------------------

    @property
    def complete(self) -> bool:
        """The fire simulator says every reporter has finished the last tick."""
        return self.status is not None and self.status.values.get("complete") == "true"

    def trajectory(self) -> np.ndarray:
        """(T, N, 4) states in time order.

        Lockstep: the states of every tick all aircraft reported. Real time (stamps differ
        between aircraft): each aircraft's states in order, cut to the shortest history.
        """
        if self.lockstep:
            common = sorted(set.intersection(*(set(s) for s in self.states)))
            return np.array([[self.states[k][t] for k in range(self.n)] for t in common])
        length = min(len(s) for s in self.states)
        if length == 0:
            return np.zeros((0, self.n, 4))
        per_aircraft = [[s[t] for t in sorted(s)][:length] for s in self.states]
        return np.stack([np.array(rows) for rows in per_aircraft], axis=1)


__all__ = ["REPORTER", "RunMonitorNode"]
