"""Start the distributed system as OS processes, watch it, stop it, summarise it.

One process per node: ``fire_simulator``, ``belief_aggregator`` and ``agent`` per aircraft
(``/uavK``), each ``python -m <package>.<node module> --ros-args ...`` — except that the agents
may share processes, ``RunSpec.agents_per_process`` to one (composed agents,
:mod:`wildfire_bringup.agent_processes`; by default above 8 aircraft). The launcher's own
process spins the :class:`RunMonitorNode` and, with a record directory, the rosbag2
:class:`BagRecorder` in one executor. What runs, and each command line, is
:mod:`wildfire_bringup.run_spec`.

Every child gets the run's ``ROS_DOMAIN_ID`` (a run-unique id unless the user set one) and
the loopback-only settings of both DDS implementations (unless the user set their own, see
:mod:`wildfire_ros.network_defaults`), so nothing leaves the machine. A child's output goes to
``<log dir>/<process>.log``; a child is stopped with the launcher even when the launcher is
killed. When a child dies the launcher names it (every node of a composed process), its exit
status and the last line it wrote, finalizes the recording and stops the rest — or, with
``respawn`` in real time, starts it again (an agent continues from its last published state,
the aggregator recovers the belief from the agents). Under limited radio links
(``RunSpec.comm``) the aggregator is a ground station no decision depends on: when it dies the
run flies on without it. With ``RunSpec.foxglove_port`` a ``live_view`` node serves the run to
Foxglove (:mod:`wildfire_bringup.live_view_node`); it reports to no one, and the run flies on
if it dies.

With ``RunSpec.hosts`` the run spreads over that many virtual hosts, Linux network namespaces on
a bridge of their own (:mod:`wildfire_testbed.hosts`): the launcher joins host 0 before its
participant exists, every child starts under ``ip netns exec`` with its host's DDS settings, and
the namespaces are removed when the run ends, fails or is interrupted. ``RunSpec.netem`` impairs
every host's link and ``RunSpec.partitions`` cut hosts off and heal them on schedule
(:mod:`wildfire_testbed.netfaults`); a cut host's nodes are *unreachable*, not dead (only a
process that exits is), and the run goes on: :class:`PartitionSchedule` logs the cut and the heal
and, from the monitor's receipt times, when each unreachable node was heard again.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from wildfire_belief.sensors import sensing_text
from wildfire_bringup.agent_processes import describe_nodes
from wildfire_bringup.monitor_node import RunMonitorNode
from wildfire_bringup.partition_schedule import PartitionSchedule
from wildfire_bringup.run_spec import (
    LIVE_VIEW,
    RunSpec,
    node_commands,
    process_commands,
    with_ground_file,
)
from wildfire_msgs_py.contract import DECISION_PERIOD_NS
from wildfire_ros.network_defaults import apply_local_network_defaults
from wildfire_testbed.hosts import VirtualHosts

if TYPE_CHECKING:
    from collections.abc import Callable

FATAL_ON_DEATH = ("fire_simulator",)
"""Nodes that cannot be respawned: a new fire simulator would restart the truth."""


class NodeFailure(Exception):
    """A node of the system died; the message names it and why."""


def child_environment(extra: dict[str, str] | None = None) -> dict[str, str]:
    """Environment of the children: loopback DDS and a run-unique domain unless set."""
    env = dict(os.environ)
    apply_local_network_defaults(env)
    # Domain ids 1..100 stay within Cyclone's port range for our participant counts.
    env.setdefault("ROS_DOMAIN_ID", str(1 + (os.getpid() + int(time.time())) % 100))
    env["PYTHONUNBUFFERED"] = "1"
    # One torch (OpenMP) thread per node: the system already runs one process per node, and
    # intra-op threads only fight the other nodes for the cores (on this 2-core machine, the
    # fire's spread convolution took 16 ms on 2 contended threads and 0.9 ms on one).
    env.setdefault("OMP_NUM_THREADS", "1")
    env.update(extra or {})
    return env


def _stop_with_parent() -> None:
    """In the child, before exec: SIGTERM it when the launcher dies, even by SIGKILL.

    A node of a launcher that was killed (or a test runner that timed out) would otherwise
    spin on with nobody to stop it. Linux only (``prctl(PR_SET_PDEATHSIG)``); elsewhere the
    launcher's own clean-up is all there is.
    """
    if sys.platform != "linux":
        return
    import ctypes

    pr_set_pdeathsig = 1
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(pr_set_pdeathsig, signal.SIGTERM)


def last_line(path: Path) -> str:
    """Last non-empty line of a log file (what a dying node said)."""
    try:
        lines = [line.strip() for line in path.read_text(errors="replace").splitlines()]
    except OSError:
        return ""
    lines = [line for line in lines if line]
    return lines[-1] if lines else ""


class Launcher:
    """Runs one episode of the distributed system (see the module docstring)."""

    def __init__(self, spec: RunSpec) -> None:
        self.spec = spec = with_ground_file(spec)
        self.env = child_environment(spec.extra_env)
        self.log_dir = spec.log_dir or Path(tempfile.mkdtemp(prefix="wildfire-run-"))
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.processes: dict[str, subprocess.Popen[bytes]] = {}
        self.layout = spec.processes()
        """The nodes of every process, by process name."""
        self.network = (
            VirtualHosts(spec.n_aircraft, spec.hosts, self.log_dir, spec.netem, spec.seed)
            if spec.hosts
            else None
        )
        self.partitions: PartitionSchedule | None = None
        self.respawns: dict[str, int] = {}
        self.lost: dict[str, str] = {}
        """Nodes the run flew on without: the ground station under limited links."""
        self.recorder: Any = None
        self.monitor: RunMonitorNode | None = None
        self.executor: Any = None
        self.wall_s = 0.0
        # Wall time from the first tick to the end of the episode: the speed of the running
        # system, without process start-up (imports, DDS discovery) and shut-down.
        self.flight_wall_s = 0.0
        self.flight_cpu_s = float("nan")
        """CPU time the node processes spent over the same span (Linux; NaN elsewhere)."""

    # --- processes ----------------------------------------------------------------------------

    def start_node(self, name: str, command: list[str]) -> None:
        log = open(self.log_dir / f"{name}.log", "ab")  # noqa: SIM115 (kept by the child)
        env = self.env
        first = self.layout[name][0]  # a composed process's nodes share one host
        if self.spec.agent_backend is not None and first.startswith("uav"):
            env = {**env, "WILDFIRE_ROS_BACKEND": self.spec.agent_backend}
        if self.network is not None:
            env = self.network.environment(first, env)
            command = self.network.command(first, command)
        self.processes[name] = subprocess.Popen(
            command,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # Ctrl-C reaches the launcher only: it stops the children
            preexec_fn=_stop_with_parent,
        )
        log.close()

    def check_children(self) -> None:
        """Raise :class:`NodeFailure` for a dead child (or respawn it)."""
        for name, process in list(self.processes.items()):
            status = process.poll()
            if status is None:
                continue
            why = last_line(self.log_dir / f"{name}.log") or "no output"
            how = f"signal {-status}" if status < 0 else f"exit status {status}"
            nodes = self.layout[name]
            if name == LIVE_VIEW:
                # Nothing depends on the live view: fly on without it (never respawned:
                # a port taken stays taken).
                print(f"wildfire run: node {name} died ({how}): {why}; flying on", file=sys.stderr)
                self.lost[name] = f"died ({how}): {why}"
                del self.processes[name]
                continue
            if self.spec.respawn and not self.spec.lockstep and name not in FATAL_ON_DEATH:
                for node in nodes:
                    self.respawns[node] = self.respawns.get(node, 0) + 1
                what = describe_nodes(nodes, name)
                print(f"wildfire run: {what} died ({how}): respawning", file=sys.stderr)
                states: dict[int, Any] = {}
                for node in nodes:
                    if node.startswith("uav") and self.monitor is not None:
                        k = int(node[3:])
                        newest = self.monitor.states[k].latest()
                        states |= {k: newest[1]} if newest else {}
                self.start_node(name, process_commands(self.spec, states or None)[name])
                continue
            if self.spec.limited_links and name == "belief_aggregator":
                # No decision depends on the ground station: fly on, scoring the union of
                # visits in the monitor.
                print(f"wildfire run: node {name} died ({how}): flying on", file=sys.stderr)
                self.lost[name] = f"died ({how}): {why}"
                del self.processes[name]
                continue
            raise NodeFailure(f"{describe_nodes(nodes, name)} died ({how}): {why}")

    def _drain(
        self, limit_s: float, quiet_s: float = 0.5, until: Callable[[], bool] = lambda: True
    ) -> None:
        """Take what is still in flight: the last belief, score and deadline messages, and the
        recorder's backlog on a loaded machine. Spins until nothing has arrived for
        ``quiet_s`` (a ``spin_once`` that returns before its timeout did some work) and
        ``until()`` holds, for ``limit_s`` at most."""
        period_s = 0.05
        start = last_work = time.monotonic()
        while (
            (now := time.monotonic()) - last_work < quiet_s or not until()
        ) and now - start < limit_s:
            self.executor.spin_once(timeout_sec=period_s)
            if time.monotonic() - now < 0.9 * period_s:
                last_work = time.monotonic()

    def children_cpu_s(self) -> float:
        """User and system CPU seconds of the running node processes (``/proc``, Linux)."""
        ticks_per_s = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
        total = 0.0
        for process in self.processes.values():
            try:
                fields = Path(f"/proc/{process.pid}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                return float("nan")
            total += (int(fields[11]) + int(fields[12])) / ticks_per_s  # utime, stime
        return total

    def stop_children(self, timeout_s: float = 5.0) -> None:
        """SIGINT every child, then SIGKILL what is left after ``timeout_s``."""
        for process in self.processes.values():
            if process.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(process.pid, signal.SIGINT)
        end = time.monotonic() + timeout_s
        for process in self.processes.values():
            try:
                process.wait(timeout=max(0.1, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()

    # --- running ------------------------------------------------------------------------------

    def run(
        self, progress: Callable[[int], None] | None = None, timeout_s: float | None = None
    ) -> RunMonitorNode:
        """Start everything, wait for the end of the episode, stop; return the monitor.

        On virtual hosts, inside them: this thread joins host 0 first and the namespaces go
        away after the nodes stopped, on every way out (also :class:`KeyboardInterrupt`).
        """
        if self.network is None:
            return self._run(progress, timeout_s)
        with self.network:
            if self.network.removed_stale:
                stale = ", ".join(self.network.removed_stale)
                print(
                    f"wildfire run: removed the namespaces of a dead run: {stale}", file=sys.stderr
                )
            return self._run(progress, timeout_s)

    def _run(
        self, progress: Callable[[int], None] | None, timeout_s: float | None
    ) -> RunMonitorNode:
        from wildfire_ros import runtime

        os.environ["ROS_DOMAIN_ID"] = self.env["ROS_DOMAIN_ID"]
        apply_local_network_defaults()
        # The children run on the launcher's backend (unless the spec mixes them).
        self.env.setdefault("WILDFIRE_ROS_BACKEND", runtime.BACKEND)
        runtime.rclpy.init(args=[])
        start = time.monotonic()
        try:
            self.executor = runtime.make_executor()
            self.monitor = RunMonitorNode(
                self.spec.n_aircraft,
                self.spec.lockstep,
                self.spec.seed,
                union_score=self.spec.lockstep,
                shape=self.spec.shape,
                radio=self.spec.limited_links,
                sensor=self.spec.sensor,
                pixel_error=self.spec.pixel_error,
                wind_filter=self.spec.wind_filter,
                ground=self.spec.ground,
            )
            self.executor.add_node(self.monitor)
            if self.spec.record_dir is not None:
                from wildfire_ros.bag import SENSOR_KEY, WIND_FILTER_KEY, BagRecorder

                # Lockstep bags log sim time (/clock), so `bag play` replays them at sim pace.
                # The world of the run travels with its bag (what rebuilding needs to know).
                sensing = {SENSOR_KEY: sensing_text(self.spec.sensor, self.spec.pixel_error)}
                if self.spec.wind_filter:
                    sensing[WIND_FILTER_KEY] = "true"
                self.recorder = BagRecorder(
                    self.spec.record_dir,
                    discovery_period=0.2,
                    use_sim_time=self.spec.lockstep,
                    custom_data=sensing,
                )
                self.executor.add_node(self.recorder.node)
            for name, command in process_commands(self.spec).items():
                self.start_node(name, command)
            if self.network is not None and self.spec.partitions:
                self.partitions = PartitionSchedule(
                    self.spec.partitions, self.network, self.monitor
                )
            extra = self.partitions.extra_time_s if self.partitions is not None else 0.0
            limit = timeout_s or (60.0 + 20.0 * self.spec.duration_s + extra)
            last_check = 0.0
            first_tick: float | None = None
            first_tick_cpu = float("nan")
            while not self.monitor.complete:
                self.executor.spin_once(timeout_sec=0.05)
                now = time.monotonic()
                status = self.monitor.status
                if first_tick is None and status is not None and status.tick >= 1:
                    first_tick = now
                    first_tick_cpu = self.children_cpu_s()
                if self.partitions is not None and first_tick is not None:
                    self.partitions.step(now - first_tick, now)
                if now - last_check > 0.2:
                    last_check = now
                    self.check_children()
                    if progress is not None and self.monitor.status is not None:
                        progress(max(self.monitor.status.tick, 0))
                if now - start > limit:
                    raise NodeFailure(f"the episode did not end within {limit:.0f} s of wall time")
            if first_tick is not None:
                self.flight_wall_s = time.monotonic() - first_tick
                self.flight_cpu_s = self.children_cpu_s() - first_tick_cpu
            # Real-time nodes publish until they are stopped: never quiet, so bounded short.
            # In lockstep the final belief is on its way (the aggregator sends it before its
            # last acknowledgement); a whole field map can take longer than a quiet half
            # second on a loaded machine, and the recording should end with it.
            monitor = self.monitor
            final_ns = (monitor.status.tick if monitor.status else 0) * DECISION_PERIOD_NS
            awaited = self.spec.lockstep and not self.spec.limited_links
            self._drain(
                limit_s=5.0 if self.spec.lockstep else 0.5,
                until=lambda: not awaited or monitor.belief_stamp >= final_ns,
            )
            if self.partitions is not None:
                now = time.monotonic()
                self.partitions.finish(now - (first_tick or now), now)
            return self.monitor
        finally:
            self.wall_s = time.monotonic() - start
            self.stop_children()
            if self.recorder is not None:
                self.recorder.close()
            if self.monitor is not None:
                self.monitor.destroy_node()
            runtime.rclpy.try_shutdown()


__all__ = [
    "Launcher",
    "NodeFailure",
    "RunSpec",
    "child_environment",
    "node_commands",
    "process_commands",
    "with_ground_file",
]
