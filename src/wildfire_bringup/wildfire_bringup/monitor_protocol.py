"""The run monitor without ROS: decoded messages in, the ticks to acknowledge out.

:class:`RunMonitor` is everything the run monitor node (``monitor_node``) does apart from
decoding messages and publishing acknowledgements, so what it collects and when it
acknowledges can be tested with plain calls (``tests/test_monitor_protocol.py``). Each
``on_*`` method takes one checked input (``wildfire_msgs_py.wire_checks``); those that can
make a lockstep tick complete return the stamps (ns) of the ticks now to acknowledge, in
order. An input that must be dropped raises
:class:`~wildfire_msgs_py.input_guard.RejectedMessage`, which the node's guard counts.

What it keeps: every aircraft's exact states by stamp, the final truth (fire and fuel maps),
every cell that burned on any fire map (for the score ceiling), the shared belief and its
exact ages, the score, each agent's deadline and radio statistics, every node's drop counts
and the episode status. With ``union_score`` (lockstep) it merges every aircraft's visits
itself, with the aggregator's own functions (under noisy sensing the filtered belief,
scored against the fire map of each tick), and acknowledges a tick only once its visits are
merged, so the run's score is that of the union of visits (what ``wildfire eval`` scores).
"""

from __future__ import annotations

import bisect
import time
from collections.abc import Iterable

import numpy as np

from wildfire_belief.aggregator import BeliefAggregator
from wildfire_belief.filtered_aggregator import FilteredAggregator
from wildfire_belief.sensors import noisy, report_window, sensors_of
from wildfire_bringup.trajectory import stacked_trajectory
from wildfire_msgs_py import contract
from wildfire_msgs_py.belief_codec import belief_probability, believed_burning
from wildfire_msgs_py.belief_delta import Frame
from wildfire_msgs_py.codecs import NodeStatus, VisitWindow
from wildfire_msgs_py.grid_tiles import Tile, TiledMap
from wildfire_msgs_py.input_guard import (
    INPUT_STATUS,
    DropReason,
    InputGuard,
    RejectedMessage,
    TickInbox,
    check_status_tick,
)
from wildfire_msgs_py.system_codecs import EpisodeStatus
from wildfire_sim.episode import DECISION_PERIOD_NS as TICK_NS
from wildfire_sim.episode import (
    DECISIONS_PER_FIRE_STEP,
    EPISODE_DEFAULTS,
    fire_step_tick,
)
from wildfire_sim.fire_protocol import NAME as FIRE_NODE
from wildfire_sim.ignition import ignite
from wildfire_sim.landscape import PAPER_LANDSCAPE, Landscape

REPORTER = "wildfire_run"
"""The monitor's name as a lockstep reporter (on ``/wildfire/ack``)."""
MAX_STATUS_STEP = 2 * DECISIONS_PER_FIRE_STEP
"""Ticks the episode status may jump at once before it is refused."""


class RunMonitor:
    """What the run monitor collects, and the ticks it acknowledges (see the module
    docstring); ``guard`` counts the node's own dropped inputs."""

    def __init__(
        self,
        n_aircraft: int,
        lockstep: bool,
        seed: int,
        guard: InputGuard,
        union_score: bool = False,
        shape: str = "circular",
        sensor: str = "disc",
        pixel_error: float = 0.0,
        preburn_steps: int = EPISODE_DEFAULTS.preburn_steps,
        wind_filter: bool = False,
        ground: Landscape = PAPER_LANDSCAPE,
        border_cells: int = EPISODE_DEFAULTS.border_cells,
    ) -> None:
        self.seed = seed
        self.geometry = ground.geometry
        self.n = n_aircraft
        self.lockstep = lockstep
        self.input_guard = guard
        self.states: list[TickInbox[np.ndarray]] = [
            TickInbox(TICK_NS if lockstep else None) for _ in range(n_aircraft)
        ]
        self.fire_stamp = -1
        self.status: EpisodeStatus | None = None
        self.fire: np.ndarray | None = None
        self.burned: np.ndarray | None = None
        self.fuel: np.ndarray | None = None
        self.fuel_map = TiledMap()
        """The fuel, whole now and then and tiles between (``wildfire_msgs_py.grid_tiles``)."""
        self.belief: np.ndarray | None = None
        self.belief_stamp = -1
        self.ages: np.ndarray | None = None
        self.ground_score = 0.0
        """The belief aggregator's score (the ground station's)."""
        self.union: BeliefAggregator | FilteredAggregator | None = None
        self.filtered: FilteredAggregator | None = None
        self.visits: list[TickInbox[VisitWindow]] = []
        self.sources = sensors_of(sensor)
        """Report windows per aircraft and decision (one per camera)."""
        self.report_side = report_window(sensor)
        self.fire_maps: dict[int, np.ndarray] = {}
        """Fire maps by stamp: the truth the score under noise needs at each tick."""
        if union_score and noisy(sensor, pixel_error):
            self.union = self.filtered = FilteredAggregator(
                seed, shape, pixel_error, preburn_steps, wind_filter, ground, border_cells
            )
        elif union_score:
            ignition = ignite(seed, shape, ground, border_cells=border_cells)
            self.union = BeliefAggregator(ignition.burning)
        if union_score:
            self.visits = [TickInbox(TICK_NS) for _ in range(n_aircraft * self.sources)]
        self.deadlines: dict[int, dict[str, float]] = {}
        self.radio_links: dict[int, dict[str, float]] = {}
        self.input_drops: dict[str, dict[str, float]] = {}
        self.tick_split: dict[str, float] = {}
        """The fire simulator's latest lockstep tick split (``split_*``, ms; ``tick_split``)."""
        self.radio_bytes = np.zeros(n_aircraft, dtype=np.int64)
        self.radio_messages = np.zeros(n_aircraft, dtype=np.int64)
        self.acked_tick = -1
        # Monotonic receipt times of each node's accepted messages (its status, belief or
        # state): when a node cut off by a partition was heard again.
        self.heard: dict[str, list[float]] = {}

    # --- inputs -------------------------------------------------------------------------------

    def on_episode(self, status: EpisodeStatus) -> list[int]:
        last = -1 if self.status is None else self.status.tick
        check_status_tick(status.tick, last, self.lockstep, MAX_STATUS_STEP)
        if self.status is None or status.tick >= self.status.tick:
            self.status = status
        self._heard("fire_simulator")
        return self.report()

    def on_fire_map(self, stamp: int, fire: np.ndarray) -> list[int]:
        self.fire_stamp = self._newer(self.fire_stamp, stamp)
        self.fire = fire
        self.burned = self.fire.copy() if self.burned is None else self.burned | self.fire
        if self.filtered is not None:
            self.fire_maps[stamp] = fire
            self.merge_union()
        return self.report()

    def on_fuel_map(self, stamp: int, fuel: np.ndarray) -> None:
        self.fuel_map.on_whole(stamp, fuel)
        self.fuel = self.fuel_map.grid

    def on_fuel_tile(self, tile: Tile) -> None:
        self.fuel_map.on_tile(tile)
        self.fuel = self.fuel_map.grid

    def on_belief(self, stamp: int, probability: np.ndarray) -> None:
        self.belief_stamp = self._newer(self.belief_stamp, stamp)
        self.belief = believed_burning(probability)
        self._heard("belief_aggregator")

    def on_ages(self, ages: np.ndarray) -> None:
        self.ages = ages

    def on_belief_frame(self, frame: Frame) -> list[int]:
        """The whole shared belief of one tick (mirrored from its keyframe and delta). A tick
        completed after a newer one (its delta came late) is not the final belief: skipped."""
        if frame.stamp > self.belief_stamp:
            self.on_ages(frame.age_s)
            self.on_belief(frame.stamp, belief_probability(frame.grid))
        return []  # the belief completes no tick of the monitor's

    def on_score(self, score: float) -> None:
        # Cumulative and unstamped: an older (replayed) value is smaller.
        self.ground_score = max(self.ground_score, score)
        self._heard("belief_aggregator")

    def on_visit(self, source: int, stamp: int, window: VisitWindow) -> list[int]:
        """Report window ``source`` (aircraft ``k``'s camera ``c`` is ``k * sources + c``)."""
        self.visits[source].accept(stamp, window)
        self.merge_union()
        return self.report()

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

    def on_radio(self, k: int, size: int) -> None:
        """A radio message of aircraft ``k``, ``size`` bytes as serialized on the wire."""
        self.radio_bytes[k] += size
        self.radio_messages[k] += 1

    def on_state(self, k: int, stamp: int, vector: np.ndarray) -> list[int]:
        self.states[k].accept(stamp, vector)
        self._heard(f"uav{k}")
        return self.report()

    def on_diagnostics(self, statuses: Iterable[NodeStatus]) -> None:
        """Keep every agent's latest decision-deadline statistics, every node's drop counts
        and the fire simulator's tick split.

        Both only grow during a run: an older (replayed) status never replaces a newer one.
        """
        for status in statuses:
            numbers = {k: v for k, v in status.values.items() if isinstance(v, float)}
            k = contract.aircraft_index("/" + status.hardware_id)
            if k is not None and status.name.endswith(contract.DEADLINE_STATUS):
                if numbers.get("decisions", -1) >= self.deadlines.get(k, {}).get("decisions", 0):
                    self.deadlines[k] = numbers
            elif k is not None and status.name.endswith(contract.RADIO_STATUS):
                if numbers.get("catch_ups", -1) >= self.radio_links.get(k, {}).get("catch_ups", 0):
                    self.radio_links[k] = numbers
            elif status.hardware_id == FIRE_NODE and "split_ticks" in numbers:
                if numbers["split_ticks"] >= self.tick_split.get("split_ticks", 0):
                    self.tick_split = {
                        key: value for key, value in numbers.items() if key.startswith("split_")
                    }
            elif status.name.endswith(INPUT_STATUS):
                node = status.name.removesuffix(f": {INPUT_STATUS}")
                if numbers.get("dropped", -1) >= self.input_drops.get(node, {}).get("dropped", 0):
                    self.input_drops[node] = numbers

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

    # --- lockstep -----------------------------------------------------------------------------

    def report(self) -> list[int]:
        """Stamps of every announced tick now acknowledged: those whose next states are all
        in, with their visits and their fire map (so the score and the ceiling, which the
        summary reads from them, are complete once the episode is)."""
        acks: list[int] = []
        if not self.lockstep or self.status is None or self.status.phase == "waiting":
            return acks
        while self.acked_tick < self.status.tick:
            tick = self.acked_tick + 1
            final = self.status.final and tick >= self.status.tick
            if not final and any((tick + 1) * TICK_NS not in s for s in self.states):
                break
            if self.union is not None and self.union.ticks < tick:
                break
            if self.fire_stamp < fire_step_tick(tick) * TICK_NS:
                break
            self.acked_tick = tick
            acks.append(tick * TICK_NS)
        return acks

    # --- results ------------------------------------------------------------------------------

    @property
    def score(self) -> float:
        """The run's score: of the union of visits under limited links, else the aggregator's."""
        return float(self.union.score) if self.union is not None else self.ground_score

    def final_belief(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The belief and its ages at the end (of the union under limited links)."""
        if self.union is not None:
            return self.union.burning, self.union.age_s()
        return self.belief, self.ages

    def dropped_inputs(self) -> dict[str, dict[str, float]]:
        """Messages each node dropped (its last status), this monitor's own included."""
        own = {"dropped": float(self.input_guard.total), **self.input_guard.counts()}
        return {**self.input_drops, REPORTER: {k: float(v) for k, v in own.items()}}

    @property
    def complete(self) -> bool:
        """The fire simulator says every reporter has finished the last tick."""
        return self.status is not None and self.status.values.get("complete") == "true"

    def trajectory(self) -> np.ndarray:
        """(T, N, 4) states in time order (:func:`stacked_trajectory`)."""
        return stacked_trajectory(self.states, self.lockstep)


__all__ = ["MAX_STATUS_STEP", "REPORTER", "RunMonitor"]
