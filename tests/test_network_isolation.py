"""The network rule (issue 11 item 3): with no DDS variable set, nothing leaves the host.

See docs/deployment.md, "Network: one host by default, several hosts by choice".

Each test builds its own network namespace: loopback up, plus a veth pair (or a dummy device)
whose end ``wfx0`` has an address and carries the default route, so any multicast discovery or
unicast to another host would be transmitted on it. A short ``wildfire run`` inside the namespace
on each backend must leave ``wfx0``'s ``tx_packets`` where it was. The child environment has none
of the DDS variables, so what is tested is the runtime's own defaults
(``wildfire_ros.network_defaults``), not the loopback settings ``conftest.py`` puts in
``os.environ``.

Controls show that the counter can move: a UDP datagram routed to the default route raises it,
and the documented multi-host opt-ins (a Cyclone URI with multicast on ``wfx0``;
``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET`` for Fast DDS) make the same system transmit on it.

Only documentation address ranges are used (RFC 5737), and the packets never get further than the
veth peer inside the same namespace.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from backend_cases import BACKENDS, require_backend

# Not marked `dds`: each case picks its backend itself, so the second (dds) pass of
# scripts/test.sh would only repeat it.

WILDFIRE = str(Path(sys.executable).parent / "wildfire")
IFACE = "wfx0"
PEER = "wfx1"
# TEST-NET-1 for the namespace's own subnet, TEST-NET-2 for "another host": neither is routable.
ADDRESS = "192.0.2.2/24"
GATEWAY = "192.0.2.1"
REMOTE_HOST = "198.51.100.7"
# The gateway's link-layer address is fixed, so a routed datagram is transmitted at once instead
# of waiting on ARP (the ARP request would count too, but one packet exactly is easier to reason
# about).
GATEWAY_MAC = "02:00:00:00:00:01"

#: Every variable through which a user chooses how DDS reaches the network. The child gets none,
#: so the test exercises the defaults the runtime applies by itself.
DDS_VARIABLES = (
    "CYCLONEDDS_URI",
    "FASTRTPS_DEFAULT_PROFILES_FILE",
    "FASTDDS_DEFAULT_PROFILES_FILE",
    "ROS_AUTOMATIC_DISCOVERY_RANGE",
    "ROS_STATIC_PEERS",
    "ROS_LOCALHOST_ONLY",
    "ROS_DISCOVERY_SERVER",
)

# `wildfire run` gives up after 60 s + 20 s per simulated second; under a loaded CI machine the
# five processes' start-up alone can take a minute, so both runs simulate 10 s and the test waits
# longer than the launcher would.
RUN_DURATION_S = 10
RUN_TIMEOUT_S = 360.0


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if check and result.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {result.stderr.strip()}")
    return result


@dataclass(frozen=True)
class Namespace:
    """A throw-away network namespace with loopback and one outward interface, ``IFACE``."""

    name: str

    def exec(
        self, command: list[str], env: dict[str, str], timeout: float
    ) -> subprocess.CompletedProcess[str]:
        # `ip netns exec` keeps the environment and execs the command, so a timeout kills the
        # command itself; anything it started is reaped when the fixture tears down.
        return subprocess.run(
            ["ip", "netns", "exec", self.name, *command],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
        )

    def tx_packets(self) -> int:
        # /sys must be read from inside: `ip netns exec` mounts the namespace's own sysfs.
        counter = f"/sys/class/net/{IFACE}/statistics/tx_packets"
        return int(_ip("netns", "exec", self.name, "cat", counter).stdout)

    def settle(self, quiet_s: float = 1.0, limit_s: float = 10.0) -> int:
        """Wait until ``tx_packets`` holds still for ``quiet_s`` (link-up chatter is over)."""
        deadline = time.monotonic() + limit_s
        last = self.tx_packets()
        while time.monotonic() < deadline:
            time.sleep(quiet_s)
            now = self.tx_packets()
            if now == last:
                return now
            last = now
        raise AssertionError(f"{IFACE} kept transmitting on its own ({last} packets)")


def _namespaces_unavailable() -> str | None:
    if not sys.platform.startswith("linux"):
        return "network namespaces are Linux only"
    if os.geteuid() != 0:
        return "creating network namespaces needs root"
    if shutil.which("ip") is None:
        return "iproute2's `ip` command is not installed"
    return None


def _add_outward_interface(name: str) -> None:
    # A veth pair with both ends inside the namespace: the peer is up (a veth with its peer down
    # has no carrier and would drop rather than transmit) but has no address, so nothing answers.
    # Some kernels lack the dummy module (this one does), others veth; either serves.
    veth = _ip("-n", name, "link", "add", IFACE, "type", "veth", "peer", "name", PEER, check=False)
    if veth.returncode == 0:
        _ip("-n", name, "link", "set", PEER, "up")
        return
    dummy = _ip("-n", name, "link", "add", IFACE, "type", "dummy", check=False)
    if dummy.returncode != 0:
        pytest.skip(
            "cannot create a veth pair or a dummy device in a network namespace: "
            f"{veth.stderr.strip()} / {dummy.stderr.strip()}"
        )


def _quiet_ipv6(name: str) -> None:
    # IPv6 would send router solicitations, DAD and MLD reports on link-up all by itself; that
    # traffic is not ours and must not be mistaken for DDS. Best effort: a kernel without IPv6
    # sends none of it anyway.
    for key in ("all", "default"):
        knob = f"/proc/sys/net/ipv6/conf/{key}/disable_ipv6"
        subprocess.run(
            ["ip", "netns", "exec", name, "sh", "-c", f"echo 1 > {knob}"],
            capture_output=True,
            timeout=30,
        )


def _kill_namespace_processes(name: str) -> None:
    # Only processes inside our own namespace: whatever a timed-out run left behind.
    pids = _ip("netns", "pids", name, check=False).stdout.split()
    for pid in pids:
        with contextlib.suppress(ProcessLookupError, ValueError):
            os.kill(int(pid), signal.SIGKILL)


@pytest.fixture
def netns() -> Iterator[Namespace]:
    reason = _namespaces_unavailable()
    if reason:
        pytest.skip(reason)
    name = f"wftest-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    created = _ip("netns", "add", name, check=False)
    if created.returncode != 0:
        pytest.skip(f"cannot create a network namespace: {created.stderr.strip()}")
    try:
        _quiet_ipv6(name)
        _ip("-n", name, "link", "set", "lo", "up")
        _add_outward_interface(name)
        for command in (
            f"addr add {ADDRESS} dev {IFACE}",
            f"link set {IFACE} up",
            f"neigh replace {GATEWAY} lladdr {GATEWAY_MAC} dev {IFACE} nud permanent",
            f"route add default via {GATEWAY} dev {IFACE}",
        ):
            _ip("-n", name, *command.split())
        namespace = Namespace(name)
        namespace.settle()
        yield namespace
    finally:
        _kill_namespace_processes(name)
        _ip("netns", "del", name, check=False)


def _child_env(backend: str, **extra: str) -> dict[str, str]:
    env = {key: value for key, value in os.environ.items() if key not in DDS_VARIABLES}
    env.update(WILDFIRE_ROS_BACKEND=backend, PYTHONUNBUFFERED="1", **extra)
    return env


def _run_system(namespace: Namespace, env: dict[str, str], log_dir: Path) -> dict[str, object]:
    command = [WILDFIRE, "run", "--aircraft", "2", "--policy", "rh", "--fast", "--json"]
    command += ["--duration", str(RUN_DURATION_S), "--log-dir", str(log_dir)]
    result = namespace.exec(command, env, RUN_TIMEOUT_S)
    assert result.returncode == 0, (
        f"wildfire run exited {result.returncode}:\n{result.stderr[-3000:]}"
    )
    summary = json.loads(result.stdout)
    score = summary.get("score")
    assert isinstance(score, int | float) and math.isfinite(score), summary
    return summary


def test_the_counter_sees_a_routed_datagram_and_not_loopback(netns: Namespace) -> None:
    """The instrument itself: loopback leaves ``wfx0`` alone, one routed datagram moves it."""
    send = (
        "import socket, sys; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); "
        "s.sendto(b'wildfire', (sys.argv[1], 9))"
    )
    env = _child_env("dds")

    before = netns.tx_packets()
    assert netns.exec([sys.executable, "-c", send, "127.0.0.1"], env, 30).returncode == 0
    after_loopback = netns.tx_packets()
    assert netns.exec([sys.executable, "-c", send, REMOTE_HOST], env, 30).returncode == 0
    after_routed = netns.tx_packets()

    print(f"tx_packets: {before} -> {after_loopback} (loopback) -> {after_routed} (routed)")
    assert after_loopback == before
    assert after_routed > after_loopback


@pytest.mark.slow
@pytest.mark.timeout(RUN_TIMEOUT_S + 60)
@pytest.mark.parametrize("backend", BACKENDS)
def test_defaults_keep_the_system_off_the_network(
    netns: Namespace, backend: str, tmp_path: Path
) -> None:
    """No DDS variable set: the whole system runs, discovers itself, and sends nothing out."""
    require_backend(backend)
    before = netns.tx_packets()
    summary = _run_system(netns, _child_env(backend), tmp_path / "logs")
    after = netns.tx_packets()

    print(f"{backend}: score {summary['score']}, tx_packets {before} -> {after}")
    assert after == before, f"{backend}: {after - before} packets left through {IFACE}"


def _opt_in_env(backend: str) -> dict[str, str]:
    if backend == "dds":
        # Cyclone on the outward interface with multicast discovery: the opposite of our default.
        uri = (
            '<CycloneDDS xmlns="https://cdds.io/config"><Domain Id="any"><General>'
            f'<Interfaces><NetworkInterface name="{IFACE}"/></Interfaces>'
            "<AllowMulticast>true</AllowMulticast></General></Domain></CycloneDDS>"
        )
        return _child_env(backend, CYCLONEDDS_URI=uri)
    # Fast DDS with no profile and the documented opt-in: stock multicast discovery on the subnet.
    return _child_env(backend, ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET")


@pytest.mark.slow
@pytest.mark.timeout(RUN_TIMEOUT_S + 60)
@pytest.mark.parametrize("backend", BACKENDS)
def test_an_explicit_opt_in_does_reach_the_network(
    netns: Namespace, backend: str, tmp_path: Path
) -> None:
    """Negative control: the user's opt-in is honoured, and the counter catches the traffic.

    Without it the test above could pass because the counter never moves; this also proves that
    the runtime leaves a user's choice alone (the opt-in in docs/deployment.md works).
    """
    require_backend(backend)
    before = netns.tx_packets()
    summary = _run_system(netns, _opt_in_env(backend), tmp_path / "logs")
    after = netns.tx_packets()

    print(f"{backend} opted in: score {summary['score']}, tx_packets {before} -> {after}")
    assert after > before, f"{backend}: the opt-in sent nothing through {IFACE}"
