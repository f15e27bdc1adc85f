"""Agent node: one aircraft (namespace ``/uavK``), Dubins dynamics and its policy at 10 Hz.

Subscribes to the truth (``/wildfire/fire_map``), the episode status, every other aircraft's
``state_stamped``, and the shared belief with its exact ages; publishes ``odom``,
``bank_cmd``, ``state``, ``state_stamped`` and ``visit`` in its namespace, and its
decision-deadline statistics on ``/diagnostics``. The decision itself is
:class:`wildfire_agent.pilot.Pilot`.

Lockstep (``mode: lockstep``): message driven. For tick ``k`` announced on
``/wildfire/episode`` the node waits for the fire map of that tick's fire step, then
publishes its visit window at ``s_k`` (from tick 1), and unless the episode has ended waits
for the other aircraft's ``s_k`` (and, for a belief policy, the belief of tick ``k``),
decides ``a_k``, flies to ``s_{k+1}``, publishes it stamped ``(k + 1) * 0.1 s`` and
acknowledges tick ``k`` on ``/wildfire/ack``. Exactly the environment's order.

Real time (``mode: realtime``): a 10 Hz wall timer decides from the latest inputs, flies and
visits; a decision that ends later than its 100 ms slot counts as a missed deadline.

Every agent also keeps the last shared belief it saw and sends it on
``/wildfire/belief_snapshot`` when a restarted belief aggregator asks for it.

Every input is checked (:mod:`wildfire_msgs_py.wire_checks`) and kept by stamp in a
:class:`~wildfire_msgs_py.input_guard.TickInbox`: the first message of a stamp counts, and
replays, stamps far ahead and malformed messages are dropped and counted in the node's
``/diagnostics`` (see ``docs/deployment.md``, "Security").
"""

from __future__ import annotations

import functools
import sys
import time
from typing import Any

import numpy as np

from wildfire_agent import dynamics
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.pilot import Pilot
from wildfire_agent.policy_names import BUILTIN_POLICIES, EXPECTED_POLICIES
from wildfire_agent.receding_horizon import RecedingHorizonConfig
from wildfire_belief.visits import visit_windows, window_values
from wildfire_msgs_py import contract
from wildfire_msgs_py.codecs import (
    NodeStatus,
    VisitWindow,
    bank_cmd_to_msg,
    diagnostics_to_msg,
    pose_to_odometry,
    state_to_msg,
    visit_to_msg,
)
from wildfire_msgs_py.input_guard import (
    DropReason,
    InputGuard,
    RejectedMessage,
    TickInbox,
    check_status_tick,
)
from wildfire_msgs_py.node_support import (
    ParamSpec,
    contract_publisher,
    contract_subscription,
    declare_parameters,
    run_node,
)
from wildfire_msgs_py.runtime import Node
from wildfire_msgs_py.system_codecs import (
    READY_SUFFIX,
    BeliefSnapshot,
    ack_to_msg,
    snapshot_to_msg,
    stamped_state_to_msg,
)
from wildfire_msgs_py.wire_checks import (
    checked_age_image,
    checked_episode,
    checked_fire_grid,
    checked_score,
    checked_stamped_state,
)
from wildfire_sim.episode import (
    DECISION_PERIOD_NS,
    DECISIONS_PER_FIRE_STEP,
    EPISODE_DEFAULTS,
    fire_step_tick,
)

PERIOD_S = DECISION_PERIOD_NS / 1e9
DEADLINE_EVERY_DECISIONS = 10
"""Deadline statistics go out at 1 Hz: every message costs each node a publish."""
FIRE_STEP_NS = DECISIONS_PER_FIRE_STEP * DECISION_PERIOD_NS
AHEAD_TICKS = 2 * DECISIONS_PER_FIRE_STEP
"""How far past the announced tick an honest input can be stamped (fire maps run one fire
step ahead at most; statuses, states and beliefs a tick or two): anything further is refused."""
REALTIME_AHEAD_NS = 10_000_000_000
"""Real time: stamps more than 10 s past the node clock are refused (clock skew allowance)."""
REQUEST_ANSWER_PERIOD_S = 1.0
"""A belief snapshot (160 kB) goes out at most once a second, whoever asks."""
MAX_BANK_RAD = float(dynamics.MAX_BANK_STEPS * dynamics.BANK_STEP_RAD)
PARAMETERS = (
    ParamSpec("aircraft", 0, "index k of this aircraft (namespace /uavK)", 0, 63),
    ParamSpec("n_aircraft", 2, "aircraft in the team", 1, 64),
    ParamSpec("policy", "rh", EXPECTED_POLICIES),
    ParamSpec(
        "seed", EPISODE_DEFAULTS.seed, "episode seed (the aircraft's random stream)", 0, 2**31 - 1
    ),
    ParamSpec("start_x", 500.0, "start position east, m", -10_000.0, 11_000.0),
    ParamSpec("start_y", 500.0, "start position north, m", -10_000.0, 11_000.0),
    ParamSpec("start_heading", 0.0, "start heading, rad counter-clockwise from east", -7.0, 7.0),
    ParamSpec("start_bank_steps", 0, "start bank in 5 degree steps", -10, 10),
    ParamSpec(
        "mode", "lockstep", "lockstep (sim time) or realtime", choices=("lockstep", "realtime")
    ),
    ParamSpec("rh_horizon", 60, "receding horizon: decisions planned ahead", 2, 400),
    ParamSpec("rh_replan_every", 10, "receding horizon: decisions flown per plan", 1, 399),
    ParamSpec("rh_restarts", 4, "receding horizon: random restarts per plan", 1, 64),
    ParamSpec("torch_threads", 1, "CPU threads of the Q-network", 1, 64),
)


def _state_vector(state: AircraftState) -> np.ndarray:
    return np.array(
        [state.x_m[0], state.y_m[0], state.heading_rad[0], state.bank_rad[0]], dtype=np.float64
    )


class DeadlineStats:
    """Decision-time statistics of the 10 Hz loop."""

    def __init__(self) -> None:
        self.decisions = 0
        self.missed = 0
        self.compute_s_total = 0.0
        self.compute_s_max = 0.0
        self.late_s_max = 0.0

    def add(self, compute_s: float, late_s: float) -> None:
        self.decisions += 1
        self.compute_s_total += compute_s
        self.compute_s_max = max(self.compute_s_max, compute_s)
        self.late_s_max = max(self.late_s_max, late_s)
        if late_s + compute_s > PERIOD_S:
            self.missed += 1

    def level(self) -> str:
        """Diagnostic level: OK under 1 % missed deadlines, WARN under 10 %, else ERROR."""
        fraction = self.missed / max(self.decisions, 1)
        return "OK" if fraction < 0.01 else "WARN" if fraction < 0.1 else "ERROR"

    def as_dict(self) -> dict[str, float | int]:
        return {
            "decisions": self.decisions,
            "missed": self.missed,
            "missed_fraction": self.missed / max(self.decisions, 1),
            "compute_ms_mean": 1e3 * self.compute_s_total / max(self.decisions, 1),
            "compute_ms_max": 1e3 * self.compute_s_max,
            "late_ms_max": 1e3 * self.late_s_max,
        }


class AgentNode(Node):
    """One aircraft (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("agent", **kwargs)
        p = declare_parameters(self, PARAMETERS)
        self.k: int = p["aircraft"]
        self.n: int = p["n_aircraft"]
        self.mode: str = p["mode"]
        self.seed: int = p["seed"]
        self.name_tag = f"uav{self.k}"
        if self.k >= self.n:
            raise AgentConfigError(f"aircraft {self.k}: expected 0..{self.n - 1} (n_aircraft)")
        if p["policy"] not in BUILTIN_POLICIES:  # a Q-network (obs, belief or a .pt file)
            import torch

            torch.set_num_threads(p["torch_threads"])
        self.pilot = Pilot(
            p["policy"],
            self.k,
            self.n,
            p["seed"],
            RecedingHorizonConfig(p["rh_horizon"], p["rh_replan_every"], p["rh_restarts"]),
        )
        self.state = AircraftState(
            x_m=np.array([p["start_x"]]),
            y_m=np.array([p["start_y"]]),
            heading_rad=np.array([p["start_heading"]]),
            bank_steps=np.array([p["start_bank_steps"]], dtype=np.int64),
        )
        tick_ns = DECISION_PERIOD_NS if self.mode == "lockstep" else None
        self.peer_states: dict[int, TickInbox[np.ndarray]] = {
            j: TickInbox(tick_ns) for j in range(self.n) if j != self.k
        }
        self.fire: TickInbox[np.ndarray] = TickInbox(FIRE_STEP_NS)
        self.belief: TickInbox[np.ndarray] = TickInbox(tick_ns)
        self.ages: TickInbox[np.ndarray] = TickInbox(tick_ns)
        self.score = 0.0
        self.status_tick = -1
        self.final_tick: int | None = None
        self.running = False
        self.visited_tick = 0  # tick 0 has no visit: the belief starts from the ignition
        self.decided_tick = -1
        self.ready_sent = False
        self.last_answer_s = -float("inf")
        self.stats = DeadlineStats()
        self.input_guard = InputGuard(self.get_logger().warning)
        self.slot_start: float | None = None

        def publisher(spec: contract.TopicSpec) -> Any:
            return contract_publisher(self, spec, self.k if spec.per_aircraft else None)

        self.odom_pub = publisher(contract.ODOM)
        self.bank_pub = publisher(contract.BANK_CMD)
        self.state_pub = publisher(contract.STATE)
        self.stamped_pub = publisher(contract.STATE_STAMPED)
        self.visit_pub = publisher(contract.VISIT)
        self.diagnostics_pub = publisher(contract.DIAGNOSTICS)
        self.ack_pub = publisher(contract.ACK)
        self.snapshot_pub = publisher(contract.BELIEF_SNAPSHOT)

        guard = self.input_guard
        # Deep reader histories on the inputs lockstep waits for: a flood on a keyless topic
        # must not push the honest sample out of the queue before the executor takes it.
        deep_latched = contract.QosSpec(depth=100, transient_local=True)
        contract_subscription(
            self, contract.FIRE_MAP, self.fire_map_callback, qos=deep_latched, guard=guard
        )
        contract_subscription(
            self, contract.EPISODE, self.episode_callback, qos=deep_latched, guard=guard
        )
        # The shared belief is an input of belief policies, and in real time each agent keeps
        # a copy for an aggregator that restarts (lockstep runs never respawn): a lockstep
        # agent flying another policy skips two 100 x 100 grids per tick.
        if self.pilot.needs_belief or self.mode == "realtime":
            for spec, callback in (
                (contract.BELIEF, self.belief_callback),
                (contract.BELIEF_AGE_EXACT, self.belief_age_callback),
            ):
                contract_subscription(self, spec, callback, qos=deep_latched, guard=guard)
            contract_subscription(self, contract.SCORE, self.score_callback, guard=guard)
            contract_subscription(
                self, contract.BELIEF_REQUEST, self.belief_request_callback, guard=guard
            )
        for j in self.peer_states:
            contract_subscription(
                self,
                contract.STATE_STAMPED,
                functools.partial(self.peer_state_callback, j),
                aircraft=j,
                qos=deep_latched,
                guard=guard,
            )
        self.publish_state(0)
        self.startup_timer = self.create_timer(0.1, self.startup_timer_callback)
        self.decision_timer = (
            self.create_timer(PERIOD_S, self.decision_timer_callback)
            if self.mode == "realtime"
            else None
        )
        self.get_logger().info(f"{self.name_tag}: policy {p['policy']} ({self.mode})")

    # --- publishing ---------------------------------------------------------------------------

    def now_stamp(self, tick: int) -> int:
        """Stamp of tick ``tick`` in lockstep, the node clock in real time."""
        if self.mode == "lockstep":
            return tick * DECISION_PERIOD_NS
        return self.get_clock().now().nanoseconds

    def publish_state(self, tick: int) -> None:
        stamp = self.now_stamp(tick)
        vector = _state_vector(self.state)
        self.stamped_pub.publish(stamped_state_to_msg(vector, stamp))
        self.state_pub.publish(state_to_msg(vector))
        self.odom_pub.publish(pose_to_odometry(vector, self.k, stamp))

    def publish_visit(self, tick: int, burning: np.ndarray) -> None:
        windows = visit_windows(self.state.x_m[None], self.state.y_m[None])
        truth = window_values(burning[None], windows)[0, 0].astype(bool)
        window = VisitWindow(
            int(windows.row0[0, 0]), int(windows.col0[0, 0]), windows.visited[0, 0], truth
        )
        self.visit_pub.publish(visit_to_msg(window, self.now_stamp(tick)))

    def ack(self, tick: int) -> None:
        self.ack_pub.publish(ack_to_msg(self.name_tag, tick * DECISION_PERIOD_NS))

    # --- callbacks ----------------------------------------------------------------------------

    def startup_timer_callback(self) -> None:
        """Say ready once the aggregator listens to our visits (their QoS is volatile)."""
        if self.ready_sent:
            return
        if self.count_subscribers(contract.VISIT.resolve(self.k)) < 1:
            return
        self.ready_sent = True
        self.ack_pub.publish(ack_to_msg(self.name_tag + READY_SUFFIX, 0))
        self.destroy_timer(self.startup_timer)

    def ahead_limit_ns(self, ticks: int = AHEAD_TICKS) -> int:
        """Newest stamp an honest input can carry now (lockstep: ticks past the status)."""
        if self.mode == "lockstep":
            return (max(self.status_tick, 0) + ticks) * DECISION_PERIOD_NS
        return self.get_clock().now().nanoseconds + REALTIME_AHEAD_NS

    def fire_map_callback(self, msg: Any) -> None:
        stamp, burning = checked_fire_grid(msg)
        # Fire maps are stamped with the sim tick in both modes.
        self.fire.ceiling = (max(self.status_tick, 0) + AHEAD_TICKS) * DECISION_PERIOD_NS
        self.fire.accept(stamp, burning)
        if self.mode == "realtime":
            self.fire.discard_below(stamp)  # decide from the newest map; refuse older ones
        self.advance()

    def episode_callback(self, msg: Any) -> None:
        status = checked_episode(msg, self.seed)
        if status.phase == "waiting":
            return
        check_status_tick(status.tick, self.status_tick, self.mode == "lockstep", AHEAD_TICKS)
        self.running = True
        self.status_tick = max(self.status_tick, status.tick)
        if status.final and self.final_tick is None:
            self.final_tick = status.tick
            if self.mode == "realtime":
                self.publish_deadline(0, force=True)
        self.advance()

    def peer_state_callback(self, j: int, msg: Any) -> None:
        stamp, vector = checked_stamped_state(msg, MAX_BANK_RAD)
        states = self.peer_states[j]
        states.ceiling = self.ahead_limit_ns()
        states.accept(stamp, vector)
        if self.mode == "realtime":
            states.discard_below(stamp)  # the newest pose is the peer's pose
        self.advance()

    def belief_callback(self, msg: Any) -> None:
        self._keep_belief(self.belief, *checked_fire_grid(msg))

    def belief_age_callback(self, msg: Any) -> None:
        self._keep_belief(self.ages, *checked_age_image(msg))

    def _keep_belief(self, inbox: TickInbox[np.ndarray], stamp: int, grid: np.ndarray) -> None:
        inbox.ceiling = self.ahead_limit_ns()
        inbox.accept(stamp, grid)
        inbox.keep_newest(4)
        self.advance()

    def score_callback(self, msg: Any) -> None:
        # The score is cumulative and unstamped: an older (replayed) value is smaller.
        self.score = max(self.score, checked_score(msg))

    def belief_request_callback(self, msg: Any) -> None:
        """Send our copy of the shared belief to a (re)started aggregator (at most 1/s)."""
        common = sorted(set(self.belief.items) & set(self.ages.items))
        if not common:
            return
        now = time.monotonic()
        if now - self.last_answer_s < REQUEST_ANSWER_PERIOD_S:
            raise RejectedMessage(DropReason.RATE_LIMITED, "belief snapshot sent under 1 s ago")
        self.last_answer_s = now
        stamp = common[-1]
        snapshot = BeliefSnapshot(
            stamp / 1e9, self.score, self.belief.items[stamp], self.ages.items[stamp]
        )
        self.snapshot_pub.publish(snapshot_to_msg(snapshot))

    def decision_timer_callback(self) -> None:
        """Real time: one decision per 100 ms slot from the latest inputs."""
        newest_fire = self.fire.latest()
        if not self.running or self.final_tick is not None or newest_fire is None:
            return
        start = time.monotonic()
        if self.slot_start is None:
            self.slot_start = start
        late = max(0.0, start - self.slot_start)
        team = self.team_state(latest=True)
        belief, ages = self.latest_belief()
        if team is None or (self.pilot.needs_belief and belief is None):
            return
        fire_stamp, burning = newest_fire
        action = self.pilot.decide(team, burning, fire_stamp, belief, ages)
        self.fly(action, tick=0)
        self.publish_visit(0, burning)
        self.stats.add(time.monotonic() - start, late)
        self.publish_deadline(0)
        # Slots follow the wall clock: a late decision does not shift the next slot.
        self.slot_start += PERIOD_S * max(1, int((time.monotonic() - self.slot_start) // PERIOD_S))

    # --- lockstep -----------------------------------------------------------------------------

    def advance(self) -> None:
        """Lockstep: do whatever the inputs received so far allow for the announced ticks."""
        if self.mode != "lockstep" or not self.running:
            return
        while True:
            tick = self.decided_tick + 1
            if tick > self.status_tick:
                return
            fire_stamp = fire_step_tick(tick) * DECISION_PERIOD_NS
            burning = self.fire.get(fire_stamp)
            if burning is None:
                return
            if self.visited_tick < tick:
                self.publish_visit(tick, burning)
                self.visited_tick = tick
            if self.final_tick is not None and tick >= self.final_tick:
                self.decided_tick = tick
                self.publish_deadline(tick, force=True)
                self.ack(tick)
                return
            team = self.team_state(stamp=tick * DECISION_PERIOD_NS)
            if team is None:
                return
            belief = ages = None
            if self.pilot.needs_belief:
                stamp = tick * DECISION_PERIOD_NS
                belief, ages = self.belief.get(stamp), self.ages.get(stamp)
                if belief is None or ages is None:
                    return
            start = time.monotonic()
            action = self.pilot.decide(team, burning, fire_stamp, belief, ages)
            self.fly(action, tick + 1)
            self.stats.add(time.monotonic() - start, 0.0)
            self.publish_deadline(tick + 1)
            # What tick `tick` used is done with: later copies of it are replays.
            for states in self.peer_states.values():
                states.discard_below((tick + 1) * DECISION_PERIOD_NS)
            self.fire.discard_below(fire_step_tick(tick + 1) * DECISION_PERIOD_NS)
            self.decided_tick = tick
            self.ack(tick)

    def team_state(self, stamp: int | None = None, latest: bool = False) -> AircraftState | None:
        """Poses of the whole team (fields (n,)), own included; None while one is missing."""
        rows = []
        for j in range(self.n):
            if j == self.k:
                rows.append(_state_vector(self.state))
                continue
            states = self.peer_states[j]
            newest = states.latest()
            vector = newest[1] if latest and newest else states.get(stamp or 0)
            if vector is None:
                return None
            rows.append(vector)
        team = np.stack(rows)
        bank_steps = np.rint(team[:, 3] / dynamics.BANK_STEP_RAD).astype(np.int64)
        # Own fields come from our own state object (not via radians) to stay bit-exact.
        x, y, heading = team[:, 0].copy(), team[:, 1].copy(), team[:, 2].copy()
        bank_steps[self.k] = self.state.bank_steps[0]
        return AircraftState(x, y, heading, bank_steps)

    def latest_belief(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        common = set(self.belief.items) & set(self.ages.items)
        if not common:
            return None, None
        stamp = max(common)
        return self.belief.items[stamp], self.ages.items[stamp]

    def fly(self, action: int, tick: int) -> None:
        self.state = dynamics.step(self.state, np.array([action], dtype=np.int64))
        self.bank_pub.publish(bank_cmd_to_msg(float(self.state.bank_rad[0])))
        self.publish_state(tick)

    def publish_deadline(self, tick: int, force: bool = False) -> None:
        """Deadline statistics on ``/diagnostics`` once a second of flight, and at the end."""
        if not force and self.stats.decisions % DEADLINE_EVERY_DECISIONS:
            return
        stats = self.stats.as_dict()
        deadlines = NodeStatus(
            f"{self.name_tag}/agent: {contract.DEADLINE_STATUS}",
            self.name_tag,
            self.stats.level(),
            f"{stats['missed']} of {stats['decisions']} decisions missed their 100 ms slot",
            dict(stats),
        )
        inputs = self.input_guard.status(f"{self.name_tag}/agent", self.name_tag)
        self.diagnostics_pub.publish(diagnostics_to_msg([deadlines, inputs], self.now_stamp(tick)))


def main(args: list[str] | None = None) -> None:
    """``ros2 run wildfire_agent agent --ros-args -r __ns:=/uav0 -p aircraft:=0``."""
    sys.exit(run_node(AgentNode, "agent", args, (AgentConfigError, ValueError)))


if __name__ == "__main__":
    main()
