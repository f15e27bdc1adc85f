"""``wildfire run --hosts K``: one system on K virtual hosts (network namespaces on a bridge).

* The placement and the per-host DDS settings, without any namespace.
* Bad ``--hosts`` input and a missing ``ip`` are one line and exit status 2.
* Namespaces left by a dead launcher (SIGKILL) are removed, with the processes in them.
* On each backend, ``--hosts 4 --fast`` flies exactly what ``wildfire eval`` flies (as
  ``test_run_system.py::test_lockstep_run_equals_evaluate`` checks it), lists the hosts and their
  nodes, and stays off the machine's network: while it runs, every host namespace holds ``lo``
  and its veth only and has no default route, the bridge namespace holds the bridge and the hosts'
  veth ends only, the root namespace gained no interface, and a packet socket on the real
  interface sees no frame from or to the run's subnet. Afterwards no namespace of the run is left.
* On each backend, composed agents (``--agents-per-process``) on three hosts fly eval's flight.
* On each backend, SIGINT mid-run stops the nodes and removes every namespace.

Each system test sets ``WILDFIRE_ROS_BACKEND`` itself. They are marked ``dds`` as the other
ROS-facing tests, so the dds pass of ``scripts/test.sh`` runs them again; there the rclpy case is
skipped (the first pass ran it).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from backend_cases import BACKENDS, require_backend
from wildfire_ros.network_defaults import (
    CONFLICTING_HOST_VARIABLES,
    apply_local_network_defaults,
    host_network_environment,
)
from wildfire_testbed import hosts

WILDFIRE = str(Path(sys.executable).parent / "wildfire")
REAL_INTERFACE = "eth0"
RUN_TIMEOUT_S = 150.0
SUBNET_PREFIX = bytes([10, 213, 0])


def _namespaces_unavailable() -> str | None:
    """As ``test_network_isolation.py`` checks it (plus the project's own check)."""
    return hosts.namespaces_unavailable()


needs_namespaces = pytest.mark.skipif(
    _namespaces_unavailable() is not None, reason=str(_namespaces_unavailable())
)


def _ip(*args: str) -> str:
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30).stdout


def _namespaces_of(pid: int) -> list[str]:
    prefix = f"{hosts.NAMESPACE_PREFIX}{pid}-"
    return sorted(line.split()[0] for line in _ip("netns", "list").splitlines() if prefix in line)


def _links(namespace: str | None = None) -> set[str]:
    where = ["-n", namespace] if namespace else []
    return {link["ifname"] for link in json.loads(_ip(*where, "-j", "link", "show"))}


def _env(backend: str) -> dict[str, str]:
    return {**os.environ, "WILDFIRE_ROS_BACKEND": backend, "PYTHONUNBUFFERED": "1"}


def _start(args: list[str], backend: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [WILDFIRE, "run", *args],
        env=_env(backend),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for(
    condition: str, check: Callable[[], object], process: subprocess.Popen[str], limit: float
) -> None:
    end = time.monotonic() + limit
    while time.monotonic() < end:
        if check():
            return
        if process.poll() is not None:
            why = process.stderr.read() if process.stderr else ""
            raise AssertionError(f"the run ended before {condition}: {why}")
        time.sleep(0.1)
    raise AssertionError(f"no {condition} within {limit} s")


def _ipv4_addresses(frame: bytes) -> tuple[bytes, bytes] | None:
    """Source and destination of an Ethernet frame carrying IPv4, else None."""
    if len(frame) < 34 or frame[12:14] != b"\x08\x00":
        return None
    return frame[26:30], frame[30:34]


class SubnetSniffer:
    """Counts the frames on an interface, and those whose IPv4 source or destination lies in the
    run's subnet.

    A packet socket sees what the interface sends as well as what it receives; a frame of the run
    there would mean a path from a host namespace to the machine's network.
    """

    def __init__(self, interface: str) -> None:
        eth_p_all = 0x0003
        self.socket = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(eth_p_all))
        self.socket.bind((interface, 0))
        self.socket.settimeout(0.2)
        self.frames = 0
        self.leaked = 0
        self.sources: set[bytes] = set()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._count, daemon=True)

    def _count(self) -> None:
        while not self._stop.is_set():
            try:
                frame = self.socket.recv(65535)
            except TimeoutError:
                continue
            self.frames += 1
            addresses = _ipv4_addresses(frame)
            if addresses is None:
                continue
            self.sources.add(addresses[0])
            if any(address[:3] == SUBNET_PREFIX for address in addresses):
                self.leaked += 1

    @contextlib.contextmanager
    def running(self) -> Iterator[SubnetSniffer]:
        self._thread.start()
        try:
            yield self
        finally:
            self._stop.set()
            self._thread.join()
            self.socket.close()


def _check_isolation(pid: int, n_hosts: int, root_links: set[str]) -> None:
    """The topology of a running ``--hosts`` run (see the module docstring)."""
    names = _namespaces_of(pid)
    bridge = f"{hosts.NAMESPACE_PREFIX}{pid}-br"
    assert bridge in names and len(names) == n_hosts + 1, names
    for name in names:
        assert _ip("-n", name, "route", "show", "default").strip() == "", name
        assert _ip("-n", name, "-6", "route", "show", "default").strip() == "", name
    for i in range(n_hosts):
        assert _links(f"{hosts.NAMESPACE_PREFIX}{pid}-{i}") == {"lo", hosts.HOST_DEVICE}
    assert _links(bridge) == {"lo", hosts.BRIDGE_DEVICE} | {f"wfp{i}" for i in range(n_hosts)}
    assert "10.213." not in _ip("-n", bridge, "-4", "addr", "show")
    assert _links() == root_links, "the run created an interface in the root namespace"
    assert "10.213." not in _ip("-4", "addr", "show") + _ip("route", "show", "table", "all")


# --- no namespace needed -----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("n_hosts", "expected"),
    [
        (1, [["launcher", "fire_simulator", "belief_aggregator", "uav0", "uav1", "uav2"]]),
        (2, [["launcher", "fire_simulator", "belief_aggregator"], ["uav0", "uav1", "uav2"]]),
        (4, [["launcher", "fire_simulator"], ["belief_aggregator"], ["uav0", "uav2"], ["uav1"]]),
        (5, [["launcher", "fire_simulator"], ["belief_aggregator"], ["uav0"], ["uav1"], ["uav2"]]),
    ],
)
def test_placement(n_hosts: int, expected: list[list[str]]) -> None:
    assert hosts.place_nodes(3, n_hosts) == expected


def test_host_dds_settings_are_explicit_and_kept(tmp_path: Path) -> None:
    import xml.etree.ElementTree as ElementTree

    peers = ["10.213.0.1", "10.213.0.2", "10.213.0.3"]
    env = host_network_environment("10.213.0.2", peers, tmp_path, "host1")
    cyclone = ElementTree.fromstring(env["CYCLONEDDS_URI"])
    ns = {"c": "https://cdds.io/config"}
    interface = cyclone.find(".//c:NetworkInterface", ns)
    assert interface is not None and interface.get("address") == "10.213.0.2"
    assert cyclone.findtext(".//c:AllowMulticast", namespaces=ns) == "false"
    assert [p.get("address") for p in cyclone.iterfind(".//c:Peer", ns)] == peers

    profile_text = Path(env["FASTRTPS_DEFAULT_PROFILES_FILE"]).read_text()
    profile = ElementTree.fromstring(profile_text.split("?>", 1)[1])
    addresses = [a.text for a in profile.iter() if a.tag.endswith("address")]
    assert addresses[0] == "10.213.0.2"  # the whitelist
    assert addresses[-3:] == peers  # the initial peers
    assert "SHM" not in profile_text and "<useBuiltinTransports>false" in profile_text
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT"

    # The runtime's loopback defaults leave an explicit host configuration alone.
    mapping = dict(env)
    assert apply_local_network_defaults(mapping) == {} and mapping == env


def test_host_environment_drops_conflicting_variables(tmp_path: Path) -> None:
    network = hosts.VirtualHosts(3, 4, tmp_path)
    given = {name: "x" for name in CONFLICTING_HOST_VARIABLES} | {"CYCLONEDDS_URI": "mine"}
    env = network.environment("uav1", {**given, "ROS_DOMAIN_ID": "7"})
    assert not set(CONFLICTING_HOST_VARIABLES) & set(env)
    assert env["ROS_DOMAIN_ID"] == "7" and "10.213.0.4" in env["CYCLONEDDS_URI"]
    assert network.command("uav1", ["python"])[-2:] == [f"wfh-{os.getpid()}-3", "python"]


def test_without_root_it_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    assert "needs root" in str(hosts.namespaces_unavailable())


@pytest.mark.parametrize(
    ("args", "path", "expected"),
    [
        (["--hosts", "6"], None, "--hosts 6: at most 5 with 3 aircraft"),
        (["--hosts", "2"], "/nonexistent", "iproute2's `ip` command is not installed"),
    ],
)
def test_bad_hosts_is_one_line(args: list[str], path: str | None, expected: str) -> None:
    env = {**os.environ, **({"PATH": path} if path else {})}
    result = subprocess.run(
        [WILDFIRE, "run", "--aircraft", "3", "--duration", "5", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    assert expected in result.stderr and len(result.stderr.strip().splitlines()) == 1


# --- namespaces ----------------------------------------------------------------------------------


@needs_namespaces
def test_the_sniffer_sees_a_datagram() -> None:
    """The instrument of the isolation check, on loopback (nothing leaves the machine)."""
    with SubnetSniffer("lo").running() as sniffer:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp:
            udp.sendto(b"wildfire", ("127.0.0.1", 9))
        end = time.monotonic() + 5
        while bytes([127, 0, 0, 1]) not in sniffer.sources and time.monotonic() < end:
            time.sleep(0.05)
    assert sniffer.frames >= 1 and bytes([127, 0, 0, 1]) in sniffer.sources
    assert sniffer.leaked == 0


@needs_namespaces
def test_namespaces_of_a_dead_launcher_are_removed() -> None:
    dead = subprocess.Popen(["true"])
    dead.wait()
    names = [f"{hosts.NAMESPACE_PREFIX}{dead.pid}-{suffix}" for suffix in ("0", "br")]
    try:
        for name in names:
            _ip("netns", "add", name)
        # A node the dead launcher left running inside its host.
        left = subprocess.Popen(["ip", "netns", "exec", names[0], "sleep", "60"])
        _wait_for("process in the namespace", lambda: _ip("netns", "pids", names[0]), left, 10)
        removed = hosts.remove_stale_namespaces()
        assert sorted(removed) == sorted(names)
        assert left.wait(timeout=10) == -signal.SIGKILL
        assert _namespaces_of(dead.pid) == []
    finally:
        for name in names:
            hosts.remove_namespace(name)


def _thread_namespace() -> int:
    return os.stat("/proc/thread-self/ns/net").st_ino


@needs_namespaces
def test_a_failure_inside_the_hosts_removes_them(tmp_path: Path) -> None:
    """In process, no DDS: this thread runs in host 0 with its variables, and a failure there
    brings it back with its environment and deletes every namespace."""
    root, environ = _thread_namespace(), dict(os.environ)
    network = hosts.VirtualHosts(2, 3, tmp_path)
    with pytest.raises(RuntimeError, match="a node died"), network:
        assert _namespaces_of(os.getpid()) == sorted(
            [network.bridge_namespace, *(h.namespace for h in network.hosts)]
        )
        host0 = hosts.NETNS_DIR / network.hosts[0].namespace
        assert _thread_namespace() == os.stat(host0).st_ino != root
        assert os.environ["CYCLONEDDS_URI"] == network.environment("launcher", {})["CYCLONEDDS_URI"]
        raise RuntimeError("a node died")
    assert _thread_namespace() == root and dict(os.environ) == environ
    assert _namespaces_of(os.getpid()) == []
    assert set(network.traffic) == {h.namespace for h in network.hosts}


@needs_namespaces
@pytest.mark.dds
@pytest.mark.slow
@pytest.mark.timeout(RUN_TIMEOUT_S + 60)
@pytest.mark.parametrize("backend", BACKENDS)
def test_four_hosts_equal_eval_and_stay_off_the_network(backend: str, tmp_path: Path) -> None:
    from wildfire_learning.evaluate import evaluate
    from wildfire_learning.vec_policies import make_vec_policy
    from wildfire_world.env import EnvConfig

    require_backend(backend, own_pass_only=True)
    # Two aircraft on four hosts: every agent alone on its host (and one process less to start).
    n, seed, duration, n_hosts = 2, 5, 10.0, 4
    root_links = _links()
    args = ["--aircraft", str(n), "--policy", "rh", "--seed", str(seed), "--fast", "--json"]
    args += ["--duration", str(duration), "--wind", "0.3,-0.2", "--hosts", str(n_hosts)]
    args += ["--log-dir", str(tmp_path / "logs")]
    sniffing = (
        SubnetSniffer(REAL_INTERFACE).running()
        if REAL_INTERFACE in root_links
        else contextlib.nullcontext(None)
    )
    with sniffing as sniffer:
        process = _start(args, backend)
        try:
            _wait_for(
                "namespaces", lambda: len(_namespaces_of(process.pid)) == n_hosts + 1, process, 30
            )
            _check_isolation(process.pid, n_hosts, root_links)
            stdout, stderr = process.communicate(timeout=RUN_TIMEOUT_S)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
    assert process.returncode == 0, stderr[-3000:]
    assert _namespaces_of(process.pid) == []
    if sniffer is not None:
        print(f"{REAL_INTERFACE}: {sniffer.frames} frames during the run, {sniffer.leaked} of it")
        assert sniffer.leaked == 0, f"{sniffer.leaked} frames of 10.213.0.0/24 on {REAL_INTERFACE}"

    summary = json.loads(stdout)
    config = EnvConfig(
        n_aircraft=n, shapes=("circular",), wind=(0.3, -0.2), max_duration_s=duration
    )
    reference = evaluate(make_vec_policy("rh"), config, [seed], record=True).episodes[0]
    assert summary["backend"] == backend
    assert summary["score"] == reference.score
    assert summary["score_ceiling"] == reference.score_ceiling
    assert summary["decisions"] == reference.decisions
    assert summary["trajectory_points"] == reference.trajectory.shape[0]
    # Bit for bit: the distances the monitor computed from the received states are the ones of
    # the environment's trajectory (same float64 operations on equal inputs).
    steps = np.diff(reference.trajectory, axis=0)
    flown = np.hypot(steps[..., 0], steps[..., 1]).sum(axis=0)
    assert summary["distance_flown_m"] == flown.tolist()

    placed = [(h["address"], h["nodes"]) for h in summary["hosts"]]
    assert placed == [
        ("10.213.0.1", ["launcher", "fire_simulator"]),
        ("10.213.0.2", ["belief_aggregator"]),
        ("10.213.0.3", ["uav0"]),
        ("10.213.0.4", ["uav1"]),
    ]
    assert [h["namespace"] for h in summary["hosts"]] == [
        f"{hosts.NAMESPACE_PREFIX}{process.pid}-{i}" for i in range(n_hosts)
    ]
    # Every host sent and received over the bridge: the nodes did talk across it.
    for host in summary["hosts"]:
        assert host["traffic"]["sent_packets"] > 0 and host["traffic"]["received_packets"] > 0


@needs_namespaces
@pytest.mark.dds
@pytest.mark.slow
@pytest.mark.timeout(RUN_TIMEOUT_S + 60)
@pytest.mark.parametrize("backend", BACKENDS)
def test_composed_agents_on_hosts_equal_eval(backend: str, tmp_path: Path) -> None:
    """``--agents-per-process 2`` on three hosts: the agents' host runs uav0 and uav1 in one
    process and uav2 alone, and the flight is eval's."""
    from wildfire_learning.evaluate import evaluate
    from wildfire_learning.vec_policies import make_vec_policy
    from wildfire_world.env import EnvConfig

    require_backend(backend, own_pass_only=True)
    n, seed, duration = 3, 5, 10.0
    args = ["--aircraft", str(n), "--policy", "rh", "--seed", str(seed), "--fast", "--json"]
    args += ["--duration", str(duration), "--wind", "0.3,-0.2", "--hosts", "3"]
    args += ["--agents-per-process", "2", "--log-dir", str(tmp_path / "logs")]
    process = _start(args, backend)
    stdout, stderr = process.communicate(timeout=RUN_TIMEOUT_S)
    assert process.returncode == 0, stderr[-3000:]
    summary = json.loads(stdout)
    config = EnvConfig(
        n_aircraft=n, shapes=("circular",), wind=(0.3, -0.2), max_duration_s=duration
    )
    reference = evaluate(make_vec_policy("rh"), config, [seed]).episodes[0]
    assert summary["backend"] == backend
    assert (summary["score"], summary["decisions"]) == (reference.score, reference.decisions)
    assert summary["composed_agents"] == {"agents0": ["uav0", "uav1"]}
    assert summary["hosts"][2]["nodes"] == ["uav0", "uav1", "uav2"]


@needs_namespaces
@pytest.mark.dds
@pytest.mark.slow
@pytest.mark.timeout(RUN_TIMEOUT_S)
@pytest.mark.parametrize("backend", BACKENDS)
def test_sigint_mid_run_removes_every_namespace(backend: str, tmp_path: Path) -> None:
    require_backend(backend, own_pass_only=True)
    logs = tmp_path / "logs"
    args = ["--aircraft", "2", "--policy", "rh", "--fast", "--duration", "120", "--hosts", "3"]
    process = _start([*args, "--log-dir", str(logs)], backend)
    try:

        def nodes() -> list[int]:
            pids = (_ip("netns", "pids", name).split() for name in _namespaces_of(process.pid))
            return [int(pid) for group in pids for pid in group if int(pid) != process.pid]

        # Fire simulator, aggregator, two agents: all started in their hosts.
        _wait_for("four nodes", lambda: len(nodes()) == 4, process, 60)
        started = nodes()
        time.sleep(2.0)
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 130, stderr
    assert "interrupted" in stderr
    assert _namespaces_of(process.pid) == []
    assert [pid for pid in started if Path(f"/proc/{pid}").exists()] == []
