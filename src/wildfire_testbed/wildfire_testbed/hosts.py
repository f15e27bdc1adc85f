"""Virtual hosts for ``wildfire run --hosts K``: Linux network namespaces on a private bridge.

Topology, created by the run and removed when it ends (``<pid>`` is the launcher's process id):

* ``wfh-<pid>-br``, the bridge namespace: the bridge ``wfbr`` and one veth end per host
  (``wfp<i>``), ``lo``, and no address. It is the switch between the hosts and nothing else.
* ``wfh-<pid>-<i>`` (i = 0..K-1), host i: ``lo`` and the other veth end, ``wf0``, with the
  address ``10.213.0.<i+1>/24``. No default route: the subnet is all a host can reach.

Nothing is ever created in the root namespace (each veth pair is made in the bridge namespace
with its peer placed directly in the host's), so no link or route joins the run to the
machine's real interfaces, and two runs (two bridges) can use the same subnet side by side.

Placement (:func:`place_nodes`): host 0 runs the launcher (its run monitor and recorder) and the
fire simulator, host 1 the belief aggregator, hosts 2.. the agents round-robin, so the world, the
ground station and the aircraft talk over the network only. With two hosts, host 0 is the ground
(launcher, fire simulator, aggregator) and host 1 carries every aircraft; one host holds it all
(still cut off from the machine's network).

The launcher's own participant joins host 0 by ``setns(2)`` of the calling (main) thread before
the runtime creates any DDS entity; the threads DDS starts afterwards inherit the namespace. Node
processes start under ``ip netns exec <host>``. Every process gets its host's DDS variables
(:func:`wildfire_ros.network_defaults.host_network_environment`): both middlewares bound to
the host's address, discovery unicast to the K host addresses.

Network faults (:mod:`wildfire_testbed.netfaults`): with a :class:`NetemSpec` every host's ``wf0``
gets ``tc qdisc add ... root netem``, or, on a kernel without ``sch_netem``, the bridge namespace
runs :mod:`wildfire_testbed.netem_switch` in place of the kernel bridge; :meth:`VirtualHosts.cut`
and :meth:`VirtualHosts.heal` take a host's bridge port down and up (a partition).

Tear-down always runs: when the run ends, fails or is interrupted (:class:`VirtualHosts` is a
context manager), and at the next start for namespaces whose owner process is dead (a launcher
killed by SIGKILL); processes still inside a namespace are killed before it is deleted.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from wildfire_ros.network_defaults import CONFLICTING_HOST_VARIABLES, host_network_environment
from wildfire_testbed.netfaults import NetemSpec

if TYPE_CHECKING:
    from collections.abc import Iterator, MutableMapping
    from types import TracebackType

NAMESPACE_PREFIX = "wfh-"
SUBNET = "10.213.0."
PREFIX_LENGTH = 24
BRIDGE_DEVICE = "wfbr"
HOST_DEVICE = "wf0"
LAUNCHER = "launcher"
"""The launcher process in a placement: run monitor and, with ``--record``, the recorder."""
SWITCH_STATS = "netem-switch.json"
"""The user-space switch's counters, in the run's log directory."""
NETNS_DIR = Path("/run/netns")
"""Where ``ip netns`` keeps its named namespaces (a bind mount each)."""

_CLONE_NEWNET = 0x40000000
_OUR_NAMESPACE = re.compile(rf"^{NAMESPACE_PREFIX}(\d+)-(\d+|br)$")


class HostNetworkError(Exception):
    """The virtual hosts could not be set up; the message says which step failed."""


@dataclass(frozen=True)
class Host:
    """One virtual host: its namespace, its address and the nodes it runs."""

    namespace: str
    address: str
    nodes: tuple[str, ...]

    def summary(self) -> dict[str, Any]:
        return {"namespace": self.namespace, "address": self.address, "nodes": list(self.nodes)}


def max_hosts(n_aircraft: int) -> int:
    """Most hosts with a node each: the fire simulator's, the aggregator's, one per agent."""
    return n_aircraft + 2


def place_nodes(n_aircraft: int, n_hosts: int) -> list[list[str]]:
    """Node names per host (see the module docstring); ``n_hosts`` in 1..max_hosts."""
    if not 1 <= n_hosts <= max_hosts(n_aircraft):
        raise ValueError(f"{n_hosts} hosts for {n_aircraft} aircraft")
    agents = [f"uav{k}" for k in range(n_aircraft)]
    ground = [LAUNCHER, "fire_simulator", "belief_aggregator"]
    if n_hosts == 1:
        return [ground + agents]
    if n_hosts == 2:
        return [ground, agents]
    placement: list[list[str]] = [[LAUNCHER, "fire_simulator"], ["belief_aggregator"]]
    placement += [[] for _ in range(n_hosts - 2)]
    for k, agent in enumerate(agents):
        placement[2 + k % (n_hosts - 2)].append(agent)
    return placement


def namespaces_unavailable() -> str | None:
    """Why this process cannot create network namespaces, or None when it can."""
    if not sys.platform.startswith("linux"):
        return "network namespaces are Linux only"
    if os.geteuid() != 0:
        return "creating network namespaces needs root (run as root or without --hosts)"
    if shutil.which("ip") is None:
        return "iproute2's `ip` command is not installed"
    return None


def _ip_command() -> str:
    return shutil.which("ip") or "ip"


def _ip(*args: str) -> str:
    """Run ``ip ARGS``; its output, or :class:`HostNetworkError` naming the failed step."""
    try:
        result = subprocess.run(
            [_ip_command(), *args], capture_output=True, text=True, timeout=30, check=False
        )
    except (OSError, subprocess.TimeoutExpired) as error:
        raise HostNetworkError(f"ip {' '.join(args)}: {error}") from None
    if result.returncode != 0:
        why = (result.stderr.strip().splitlines() or ["failed"])[0]
        raise HostNetworkError(f"ip {' '.join(args)}: {why}")
    return result.stdout


def _tc(namespace: str, *args: str) -> None:
    """``tc -n NAMESPACE ARGS``, or :class:`HostNetworkError` with tc's first error line."""
    command = [shutil.which("tc") or "tc", "-n", namespace, *args]
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=30, check=False)
    except (OSError, subprocess.TimeoutExpired) as error:
        raise HostNetworkError(f"tc {' '.join(args)}: {error}") from None
    if result.returncode != 0:
        why = (result.stderr.strip().splitlines() or ["failed"])[0]
        raise HostNetworkError(f"tc {' '.join(args)}: {why}")


def list_namespaces() -> list[str]:
    """Names of the named network namespaces (``ip netns list``)."""
    return [line.split()[0] for line in _ip("netns", "list").splitlines() if line.strip()]


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_namespace(name: str) -> None:
    """Kill whatever still runs in namespace ``name`` (never this process), then delete it.

    Best effort: a namespace that is already gone, or a process that already exited, is fine.
    """
    with contextlib.suppress(HostNetworkError):
        for pid in _ip("netns", "pids", name).split():
            if pid.isdigit() and int(pid) != os.getpid():
                with contextlib.suppress(ProcessLookupError):
                    os.kill(int(pid), signal.SIGKILL)
    with contextlib.suppress(HostNetworkError):
        _ip("netns", "del", name)


def remove_stale_namespaces() -> list[str]:
    """Delete the ``wfh-<pid>-*`` namespaces whose owner process is dead; their names.

    A launcher killed by SIGKILL (or a machine losing power mid-tear-down) cannot clean up after
    itself; its namespaces would otherwise stay forever, with nodes perhaps still running in them.
    """
    removed = []
    for name in list_namespaces():
        match = _OUR_NAMESPACE.match(name)
        if match is None or _pid_alive(int(match.group(1))):
            continue
        remove_namespace(name)
        removed.append(name)
    return removed


def _setns(fd: int) -> None:
    """Move the calling thread into the network namespace behind ``fd`` (no os.setns in 3.11)."""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.setns(fd, _CLONE_NEWNET) != 0:
        errno = ctypes.get_errno()
        raise HostNetworkError(f"setns: {os.strerror(errno)}")


@contextlib.contextmanager
def _stop_signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back while tearing down: a second Ctrl-C must not leave half of
    the namespaces behind. A signal that arrived is delivered afterwards."""
    held = {signal.SIGINT, signal.SIGTERM}
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


class VirtualHosts:
    """The namespaces, bridge and DDS settings of one run on ``n_hosts`` virtual hosts.

    Planning happens at construction (no side effect). ``with hosts:`` removes stale namespaces,
    creates this run's, moves the calling thread and its DDS variables into host 0 (the
    launcher's) and, on the way out, whatever happened, moves back and deletes them all.
    """

    def __init__(
        self,
        n_aircraft: int,
        n_hosts: int,
        config_dir: Path,
        netem: NetemSpec | None = None,
        seed: int = 0,
    ) -> None:
        owner = os.getpid()
        self.bridge_namespace = f"{NAMESPACE_PREFIX}{owner}-br"
        self.hosts = [
            Host(f"{NAMESPACE_PREFIX}{owner}-{i}", f"{SUBNET}{i + 1}", tuple(nodes))
            for i, nodes in enumerate(place_nodes(n_aircraft, n_hosts))
        ]
        self.config_dir = config_dir
        self.removed_stale: list[str] = []
        self.traffic: dict[str, dict[str, int]] = {}
        """What each host's interface sent and received over the run, by namespace (read just
        before tear-down): proof that the nodes talked across the bridge."""
        self.netem = netem
        self.netem_via: str | None = None
        """How ``netem`` was applied: ``tc netem`` or ``user-space switch``."""
        self.switch_counters: dict[str, int] = {}
        self._seed = seed
        self._switch: subprocess.Popen[bytes] | None = None
        self._created: list[str] = []
        self._environments: dict[str, dict[str, str]] = {}
        self._root_fd: int | None = None
        self._saved_environ: dict[str, str | None] = {}

    # --- placement ----------------------------------------------------------------------------

    def host_of(self, node: str) -> Host:
        """The host that runs ``node`` (a node name of the launcher, or :data:`LAUNCHER`)."""
        for host in self.hosts:
            if node in host.nodes:
                return host
        raise KeyError(f"node {node!r} has no host")

    def command(self, node: str, command: list[str]) -> list[str]:
        """``command`` run inside the namespace of ``node``'s host."""
        return [_ip_command(), "netns", "exec", self.host_of(node).namespace, *command]

    def environment(self, node: str, env: dict[str, str]) -> dict[str, str]:
        """``env`` with the DDS variables of ``node``'s host (written by :meth:`create`)."""
        result = {k: v for k, v in env.items() if k not in CONFLICTING_HOST_VARIABLES}
        result.update(self._host_environment(self.host_of(node)))
        return result

    def summary(self) -> list[dict[str, Any]]:
        """The hosts for the run's JSON summary: namespace, address, nodes, traffic."""
        result = []
        for host in self.hosts:
            entry = host.summary()
            if host.namespace in self.traffic:
                entry["traffic"] = self.traffic[host.namespace]
            result.append(entry)
        return result

    def _host_environment(self, host: Host) -> dict[str, str]:
        if host.namespace not in self._environments:
            peers = [h.address for h in self.hosts]
            name = host.namespace.rsplit("-", 1)[1]
            self._environments[host.namespace] = host_network_environment(
                host.address, peers, self.config_dir, f"host{name}"
            )
        return self._environments[host.namespace]

    # --- namespaces ---------------------------------------------------------------------------

    def _add_namespace(self, name: str) -> None:
        _ip("netns", "add", name)
        self._created.append(name)
        _ip("-n", name, "link", "set", "lo", "up")

    def create(self) -> None:
        """Remove stale namespaces, then build the bridge and the hosts (see the module doc)."""
        self.removed_stale = remove_stale_namespaces()
        bridge = self.bridge_namespace
        self._add_namespace(bridge)
        _ip("-n", bridge, "link", "add", BRIDGE_DEVICE, "type", "bridge")
        _ip("-n", bridge, "link", "set", BRIDGE_DEVICE, "up")
        for i, host in enumerate(self.hosts):
            port = f"wfp{i}"
            self._add_namespace(host.namespace)
            # Created in the bridge namespace with its peer made directly in the host's: no end
            # of the pair ever exists in the root namespace.
            veth = f"link add {port} type veth peer name {HOST_DEVICE} netns {host.namespace}"
            _ip("-n", bridge, *veth.split())
            _ip("-n", bridge, "link", "set", port, "master", BRIDGE_DEVICE)
            _ip("-n", bridge, "link", "set", port, "up")
            address = f"{host.address}/{PREFIX_LENGTH}"
            _ip("-n", host.namespace, "addr", "add", address, "dev", HOST_DEVICE)
            _ip("-n", host.namespace, "link", "set", HOST_DEVICE, "up")
            self._host_environment(host)
        if self.netem is not None:
            self._impair(self.netem)

    # --- faults -------------------------------------------------------------------------------

    def _impair(self, netem: NetemSpec) -> None:
        """``netem`` on every host's link: the qdisc, or the user-space switch without it."""
        try:
            for host in self.hosts:
                qdisc = ["qdisc", "add", "dev", HOST_DEVICE, "root", "netem"]
                _tc(host.namespace, *qdisc, *netem.tc_arguments())
            self.netem_via = "tc netem"
            return
        except HostNetworkError as error:
            if "unknown" not in str(error).lower() and shutil.which("tc") is not None:
                raise
        self._start_switch(netem)

    def _start_switch(self, netem: NetemSpec) -> None:
        ports = [f"wfp{i}" for i in range(len(self.hosts))]
        for port in ports:  # the switch forwards in place of the kernel bridge
            _ip("-n", self.bridge_namespace, "link", "set", port, "nomaster")
        command = [_ip_command(), "netns", "exec", self.bridge_namespace, sys.executable]
        command += ["-m", "wildfire_testbed.netem_switch", "--ports", *ports]
        command += ["--delay-ms", str(netem.delay_ms), "--jitter-ms", str(netem.jitter_ms)]
        command += ["--loss-percent", str(netem.loss_percent), "--seed", str(self._seed)]
        command += ["--stats", str(self.config_dir / SWITCH_STATS)]
        log = open(self.config_dir / "netem-switch.log", "ab")  # noqa: SIM115 (kept by the child)
        with log:
            self._switch = subprocess.Popen(
                command, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT
            )
        # Ready once it printed its line: frames sent before would be lost.
        for _ in range(200):
            if "ready" in (self.config_dir / "netem-switch.log").read_text(errors="replace"):
                break
            if self._switch.poll() is not None:
                raise HostNetworkError("the user-space netem switch failed to start")
            time.sleep(0.05)
        self.netem_via = "user-space switch (this kernel has no sch_netem)"

    def _stop_switch(self) -> None:
        if self._switch is None:
            return
        with contextlib.suppress(ProcessLookupError):
            self._switch.terminate()
        try:
            self._switch.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self._switch.kill()
            self._switch.wait()
        self._switch = None
        with contextlib.suppress(OSError, ValueError):
            self.switch_counters = json.loads((self.config_dir / SWITCH_STATS).read_text())

    def cut(self, index: int) -> None:
        """Partition host ``index``: its bridge port goes down (the host keeps its own link)."""
        _ip("-n", self.bridge_namespace, "link", "set", f"wfp{index}", "down")

    def heal(self, index: int) -> None:
        """End the partition of host ``index``: its bridge port comes back up."""
        _ip("-n", self.bridge_namespace, "link", "set", f"wfp{index}", "up")

    def read_traffic(self) -> None:
        """Keep the packet and byte counters of every host's interface (best effort)."""
        for host in self.hosts:
            if host.namespace not in self._created:
                continue
            try:
                shown = _ip("-j", "-s", "-n", host.namespace, "link", "show", HOST_DEVICE)
                stats = json.loads(shown)[0]["stats64"]
            except (HostNetworkError, ValueError, LookupError):
                continue
            self.traffic[host.namespace] = {
                "sent_packets": int(stats["tx"]["packets"]),
                "sent_bytes": int(stats["tx"]["bytes"]),
                "received_packets": int(stats["rx"]["packets"]),
                "received_bytes": int(stats["rx"]["bytes"]),
            }

    def remove(self) -> None:
        """Kill what runs in this run's namespaces and delete them (every one, best effort)."""
        self._stop_switch()
        for name in reversed(self._created):
            remove_namespace(name)
        self._created.clear()

    # --- the launcher's own namespace ---------------------------------------------------------

    def enter(self, node: str = LAUNCHER) -> None:
        """Move the calling thread, and ``os.environ``'s DDS variables, into ``node``'s host."""
        target = self.host_of(node)
        environment = self.environment(node, {})
        for name in (*CONFLICTING_HOST_VARIABLES, *environment):
            self._saved_environ.setdefault(name, os.environ.get(name))
        _update_environ(os.environ, environment)
        try:
            self._root_fd = os.open("/proc/thread-self/ns/net", os.O_RDONLY | os.O_CLOEXEC)
            fd = os.open(NETNS_DIR / target.namespace, os.O_RDONLY | os.O_CLOEXEC)
        except OSError as error:
            raise HostNetworkError(f"cannot open a network namespace: {error}") from None
        try:
            _setns(fd)
        finally:
            os.close(fd)

    def leave(self) -> None:
        """Back to the namespace and DDS variables from before :meth:`enter`."""
        if self._root_fd is not None:
            try:
                _setns(self._root_fd)
            finally:
                os.close(self._root_fd)
                self._root_fd = None
        for name, value in self._saved_environ.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
        self._saved_environ.clear()

    def __enter__(self) -> VirtualHosts:
        try:
            self.create()
            self.enter()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        with _stop_signals_held():
            # Each step runs whatever the one before raised: the namespaces must go.
            try:
                self.leave()
            finally:
                try:
                    self.read_traffic()
                finally:
                    self.remove()


def _update_environ(environ: MutableMapping[str, str], values: dict[str, str]) -> None:
    for name in CONFLICTING_HOST_VARIABLES:
        environ.pop(name, None)
    environ.update(values)


__all__ = [
    "LAUNCHER",
    "NAMESPACE_PREFIX",
    "Host",
    "HostNetworkError",
    "VirtualHosts",
    "list_namespaces",
    "max_hosts",
    "namespaces_unavailable",
    "place_nodes",
    "remove_namespace",
    "remove_stale_namespaces",
]
