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
summary is built from the system's own messages; the dropped ones are counted.
"""

from __future__ import annotations

import bisect
import functools
import time
from typing import Any

import numpy as np

from wildfire_agent.agent_protocol import MAX_BANK_RAD
from wildfire_belief.aggregator import BeliefAggregator
from wildfire_belief.filtered_aggregator import FilteredAggregator
from wildfire_belief.sensors import noisy, report_window, sensors_of
from wildfire_bringup.trajectory import stacked_trajectory
from wildfire_msgs_py import contract
from wildfire_msgs_py.belief_codec import believed_burning
from wildfire_msgs_py.codecs import (
    VisitWindow,
    diagnostics_from_msg,
    fuel_grid_from_msg,
)
from wildfire_msgs_py.input_guard import (
    INPUT_STATUS,
    DropReason,
    InputGuard,
    RejectedMessage,
    TickInbox,
    check_status_tick,
)
from wildfire_msgs_py.system_codecs import READY_SUFFIX, EpisodeStatus, ack_to_msg
from wildfire_msgs_py.wire_checks import (
    checked_age_image,
    checked_belief_grid,
    checked_episode,
    checked_fire_grid,
    checked_score,
    checked_stamped_state,
    checked_visit,
)
from wildfire_ros.node_support import contract_publisher, contract_subscription
from wildfire_ros.runtime import Node, get_message, qos_profile
from wildfire_sim.episode import DECISION_PERIOD_NS as TICK_NS
from wildfire_sim.episode import (
    DECISIONS_PER_FIRE_STEP,
    EPISODE_DEFAULTS,
    fire_step_tick,
    initial_fire,
)

REPORTER = "wildfire_run"
MAX_STATUS_STEP = 2 * DECISIONS_PER_FIRE_STEP


class RunMonitorNode(Node):
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
    ) -> None:
        super().__init__("wildfire_run")
        self.seed = seed
        self.n = n_aircraft
        self.lockstep = lockstep
        self.states: list[TickInbox[np.ndarray]] = [
            TickInbox(TICK_NS if lockstep else None) for _ in range(n_aircraft)
        ]
        self.fire_stamp = -1
        self.status: EpisodeStatus | None = None
        self.fire: np.ndarray | None = None
        self.burned: np.ndarray | None = None
        self.fuel: np.ndarray | None = None
        self.belief: np.ndarray | None = None
        self.belief_stamp = -1
        self.ages: np.ndarray | None = None
        self.ground_score = 0.0
        """The belief aggregator's score (the ground station's)."""
        self.union: BeliefAggregator | FilteredAggregator | None = None
        self.filtered: FilteredAggregator | None = None
        self.visits: list[TickInbox[VisitWindow]] = []
        self.sources = sensors_of(sensor)
        self.report_side = report_window(sensor)
        self.fire_maps: dict[int, np.ndarray] = {}
        """Fire maps by stamp: the truth the score under noise needs at each tick."""
        if union_score and noisy(sensor, pixel_error):
            self.union = self.filtered = FilteredAggregator(
                seed, shape, pixel_error, preburn_steps, wind_filter
            )
        elif union_score:
            self.union = BeliefAggregator(initial_fire(seed, shape).burning[0])
        if union_score:
            self.visits = [TickInbox(TICK_NS) for _ in range(n_aircraft * self.sources)]
        self.deadlines: dict[int, dict[str, float]] = {}
        self.radio_links: dict[int, dict[str, float]] = {}
        self.input_drops: dict[str, dict[str, float]] = {}
        self.acked_tick = -1
        # Monotonic receipt times of each node's accepted messages (its status, belief or
        # state): when a node cut off by a partition was heard again.
        self.heard: dict[str, list[float]] = {}
        self.input_guard = InputGuard(self.get_logger().warning)
        self.ack_pub = contract_publisher(self, contract.ACK)

        def subscribe(spec: contract.TopicSpec, callback: Any, aircraft: int | None = None) -> None:
            # The monitor records every message: a deep history on every topic.
            qos = contract.QosSpec(depth=100, transient_local=spec.qos.transient_local)
            contract_subscription(
                self, spec, callback, aircraft=aircraft, qos=qos, guard=self.input_guard
            )

        subscribe(contract.EPISODE, self.episode_callback)
        subscribe(contract.FIRE_MAP, self.fire_map_callback)
        subscribe(contract.FUEL_MAP, self.fuel_map_callback)
        subscribe(contract.BELIEF, self.belief_callback)
        subscribe(contract.BELIEF_AGE_EXACT, self.belief_age_callback)
        subscribe(contract.SCORE, self.score_callback)
        for k in range(n_aircraft):
            subscribe(contract.STATE_STAMPED, lambda msg, k=k: self.state_callback(k, msg), k)
        self.radio_bytes = np.zeros(n_aircraft, dtype=np.int64)
        self.radio_messages = np.zeros(n_aircraft, dtype=np.int64)
        report_specs = contract.report_topics(sensor)
        for k in range(n_aircraft if union_score else 0):
            for c, spec in enumerate(report_specs):
                source = k * self.sources + c
                subscribe(spec, lambda msg, s=source: self.visit_callback(s, msg), k)
        for k in range(n_aircraft if radio else 0):
            self.create_subscription(
                get_message(contract.RADIO.type),
                contract.RADIO.resolve(k),
                functools.partial(self.radio_callback, k),
                qos_profile(contract.QosSpec(depth=100, transient_local=True)),
                raw=True,
            )
        subscribe(contract.DIAGNOSTICS, self.diagnostics_callback)
        self.ack_pub.publish(ack_to_msg(REPORTER + READY_SUFFIX, 0))

    # --- callbacks ----------------------------------------------------------------------------

    def episode_callback(self, msg: Any) -> None:
        status = checked_episode(msg, self.seed)
        last = -1 if self.status is None else self.status.tick
        check_status_tick(status.tick, last, self.lockstep, MAX_STATUS_STEP)
        if self.status is None or status.tick >= self.status.tick:
            self.status = status
        self._heard("fire_simulator")
        self.report()

    def fire_map_callback(self, msg: Any) -> None:
        stamp, fire = checked_fire_grid(msg)
        self.fire_stamp = self._newer(self.fire_stamp, stamp)
        self.fire = fire
        self.burned = self.fire.copy() if self.burned is None else self.burned | self.fire
        if self.filtered is not None:
            self.fire_maps[stamp] = fire
            self.merge_union()
        self.report()

    def fuel_map_callback(self, msg: Any) -> None:
        self.fuel = fuel_grid_from_msg(msg)

    def belief_callback(self, msg: Any) -> None:
        stamp, probability = checked_belief_grid(msg)
        self.belief_stamp = self._newer(self.belief_stamp, stamp)
        self.belief = believed_burning(probability)
        self._heard("belief_aggregator")

    def belief_age_callback(self, msg: Any) -> None:
        _, self.ages = checked_age_image(msg)

    def score_callback(self, msg: Any) -> None:
        # Cumulative and unstamped: an older (replayed) value is smaller.
        self.ground_score = max(self.ground_score, checked_score(msg))
        self._heard("belief_aggregator")

    def visit_callback(self, source: int, msg: Any) -> None:
        self.visits[source].accept(*checked_visit(msg, self.report_side))
        self.merge_union()
        self.report()

    def merge_union(self) -> None:
        """Merge every tick whose reports (and under noise, fire map) are all in."""
        assert self.union is not None
        while all((stamp := (self.union.ticks + 1) * TICK_NS) in inbox for inbox in self.visits):
            windows = [inbox.items[stamp] for inbox in self.visits]
            if self.filtered is not None:
                fire_stamp = fire_step_tick(self.union.ticks + 1) * TICK_NS
                truth = self.fire_maps.get(fire_stamp)
                if truth is None:
                    return
                self.filtered.merge(windows, truth)
                for older in [s for s in self.fire_maps if s < fire_stamp]:
                    del self.fire_maps[older]
            else:
                self.union.merge(windows)
            for inbox in self.visits:
                inbox.discard_below(stamp + TICK_NS)

    def radio_callback(self, k: int, data: bytes) -> None:
        self.radio_bytes[k] += len(data)
        self.radio_messages[k] += 1

    @property
    def score(self) -> float:
        """The run's score: of the union of visits under limited links, else the aggregator's."""
        return float(self.union.score) if self.union is not None else self.ground_score

    def final_belief(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The belief and its ages at the end (of the union under limited links)."""
        if self.union is not None:
            return self.union.burning, self.union.age_s()
        return self.belief, self.ages

    def state_callback(self, k: int, msg: Any) -> None:
        stamp, vector = checked_stamped_state(msg, MAX_BANK_RAD)
        self.states[k].accept(stamp, vector)
        self._heard(f"uav{k}")
        self.report()

    def _heard(self, node: str) -> None:
        self.heard.setdefault(node, []).append(time.monotonic())

    def first_heard_after(self, node: str, since: float) -> float | None:
        """Monotonic time of ``node``'s first accepted message at or after ``since``."""
        times = self.heard.get(node, [])
        i = bisect.bisect_left(times, since)
        return times[i] if i < len(times) else None

    @staticmethod
    def _newer(last_stamp: int, stamp: int) -> int:
        """``stamp``, refused unless newer than ``last_stamp`` (a latched map's replay)."""
        if stamp <= last_stamp:
            raise RejectedMessage(DropReason.STALE, f"stamp {stamp} ns <= {last_stamp} ns")
        return stamp

    def diagnostics_callback(self, msg: Any) -> None:
        """Keep every agent's latest decision-deadline statistics and every node's drop counts.

        Both only grow during a run: an older (replayed) status never replaces a newer one.
        """
        for status in diagnostics_from_msg(msg):
            numbers = {k: v for k, v in status.values.items() if isinstance(v, float)}
            k = contract.aircraft_index("/" + status.hardware_id)
            if k is not None and status.name.endswith(contract.DEADLINE_STATUS):
                if numbers.get("decisions", -1) >= self.deadlines.get(k, {}).get("decisions", 0):
                    self.deadlines[k] = numbers
            elif k is not None and status.name.endswith(contract.RADIO_STATUS):
                # Counts only grow: an older (replayed) status never replaces a newer one.
                if numbers.get("catch_ups", -1) >= self.radio_links.get(k, {}).get("catch_ups", 0):
                    self.radio_links[k] = numbers
            elif status.name.endswith(INPUT_STATUS):
                node = status.name.removesuffix(f": {INPUT_STATUS}")
                if numbers.get("dropped", -1) >= self.input_drops.get(node, {}).get("dropped", 0):
                    self.input_drops[node] = numbers

    def dropped_inputs(self) -> dict[str, dict[str, float]]:
        """Messages each node dropped (its last status), this monitor's own included."""
        own = {"dropped": float(self.input_guard.total), **self.input_guard.counts()}
        return {**self.input_drops, REPORTER: {k: float(v) for k, v in own.items()}}

    # --- lockstep -----------------------------------------------------------------------------

    def report(self) -> None:
        """Acknowledge every announced tick whose next states are all in, with its visits and
        its fire map (so the score and the ceiling, which the summary reads from them, are
        complete once the episode is)."""
        if not self.lockstep or self.status is None or self.status.phase == "waiting":
            return
        while self.acked_tick < self.status.tick:
            tick = self.acked_tick + 1
            final = self.status.final and tick >= self.status.tick
            if not final and any((tick + 1) * TICK_NS not in s for s in self.states):
                return
            if self.union is not None and self.union.ticks < tick:
                return
            if self.fire_stamp < fire_step_tick(tick) * TICK_NS:
                return
            self.acked_tick = tick
            self.ack_pub.publish(ack_to_msg(REPORTER, tick * TICK_NS))

    # --- results ------------------------------------------------------------------------------

    @property
    def complete(self) -> bool:
        """The fire simulator says every reporter has finished the last tick."""
        return self.status is not None and self.status.values.get("complete") == "true"

    def trajectory(self) -> np.ndarray:
        """(T, N, 4) states in time order (:func:`stacked_trajectory`)."""
        return stacked_trajectory(self.states, self.lockstep)


__all__ = ["REPORTER", "RunMonitorNode"]
