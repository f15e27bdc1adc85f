"""A user-space Ethernet switch that delays and drops frames, for kernels without ``sch_netem``.

``wildfire run --hosts K --netem SPEC`` applies ``tc qdisc add dev wf0 root netem SPEC`` in every
host namespace. Some kernels (minimal VM and container kernels) are built without ``sch_netem``;
there the run starts this module inside the bridge namespace instead of enslaving the hosts'
ports to the kernel bridge::

    ip netns exec wfh-<pid>-br python -m wildfire_testbed.netem_switch \\
        --ports wfp0 wfp1 ... --delay-ms 20 --jitter-ms 10 --loss-percent 2 --stats FILE

It reads every frame a host sends (a packet socket per bridge port), drops it with the loss
probability, holds it for a delay drawn uniformly from ``delay ± jitter`` (netem's default
distribution; like netem with jitter, frames may overtake each other) and then writes it to the
port that owns the destination MAC address (learnt from source addresses), or floods it to every
other port. A frame is impaired once on its way between two hosts, as netem on the sender's
egress would. ``PACKET_VNET_HDR`` carries each frame's checksum-offload state through the
switch, so the hosts keep their default offloads. A port that is down (a partition) just loses
what is sent to it. On SIGTERM or SIGINT it writes its counters to ``--stats``.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import heapq
import json
import random
import select
import signal
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

ETH_P_ALL = 0x0003
SOL_PACKET = 263
PACKET_VNET_HDR = 15
PACKET_IGNORE_OUTGOING = 23
VNET_HEADER_BYTES = 10
"""``struct virtio_net_hdr`` in front of every frame read or written with ``PACKET_VNET_HDR``."""
BUFFER_BYTES = 4 << 20
"""Socket buffers big enough for a burst of belief fragments while the switch is descheduled."""


@dataclass
class Counters:
    received: int = 0
    dropped: int = 0
    forwarded: int = 0
    unsendable: int = 0
    """Frames for a port that was down (a partitioned host) or full."""


@dataclass(order=True)
class _Held:
    due: float
    sequence: int
    frame: bytes = field(compare=False)
    ports: tuple[int, ...] = field(compare=False)


class NetemSwitch:
    """The switch over the packet sockets of ``ports`` (see the module docstring)."""

    def __init__(
        self, ports: list[str], delay_s: float, jitter_s: float, loss: float, seed: int
    ) -> None:
        self.sockets = [self._open(port) for port in ports]
        self.by_fd = {s.fileno(): i for i, s in enumerate(self.sockets)}
        self.delay_s, self.jitter_s, self.loss = delay_s, jitter_s, loss
        self.random = random.Random(seed)
        self.owner: dict[bytes, int] = {}
        self.held: list[_Held] = []
        self.sequence = 0
        self.counters = Counters()

    @staticmethod
    def _open(port: str) -> socket.socket:
        sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
        sock.setsockopt(SOL_PACKET, PACKET_VNET_HDR, 1)
        sock.setsockopt(SOL_PACKET, PACKET_IGNORE_OUTGOING, 1)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, BUFFER_BYTES)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, BUFFER_BYTES)
        sock.bind((port, 0))
        sock.setblocking(False)
        return sock

    def _destinations(self, port: int, frame: bytes) -> tuple[int, ...]:
        source = frame[VNET_HEADER_BYTES + 6 : VNET_HEADER_BYTES + 12]
        destination = frame[VNET_HEADER_BYTES : VNET_HEADER_BYTES + 6]
        self.owner[source] = port
        known = self.owner.get(destination)
        if known is not None and not destination[0] & 1:  # unicast to a learnt address
            return () if known == port else (known,)
        return tuple(i for i in range(len(self.sockets)) if i != port)

    def receive(self, port: int, now: float) -> None:
        """Take every frame waiting on ``port``: drop it or hold it for its delay."""
        sock = self.sockets[port]
        while True:
            try:
                frame = sock.recv(65536 + VNET_HEADER_BYTES)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:  # the port went down under us (a partition)
                return
            self.counters.received += 1
            if self.loss and self.random.random() < self.loss:
                self.counters.dropped += 1
                continue
            ports = self._destinations(port, frame)
            if not ports:
                continue
            delay = self.delay_s + self.random.uniform(-self.jitter_s, self.jitter_s)
            self.sequence += 1
            heapq.heappush(self.held, _Held(now + max(delay, 0.0), self.sequence, frame, ports))

    def release(self, now: float) -> None:
        """Send every held frame whose time has come."""
        while self.held and self.held[0].due <= now:
            held = heapq.heappop(self.held)
            for port in held.ports:
                try:
                    self.sockets[port].send(held.frame)
                    self.counters.forwarded += 1
                except OSError:
                    self.counters.unsendable += 1

    def run(self, stop: list[bool]) -> None:
        poller = select.poll()
        for sock in self.sockets:
            poller.register(sock, select.POLLIN)
        while not stop:
            now = time.monotonic()
            wait_ms = 200 if not self.held else max(0, int((self.held[0].due - now) * 1e3))
            with contextlib.suppress(InterruptedError):
                for fd, _ in poller.poll(wait_ms):
                    self.receive(self.by_fd[fd], time.monotonic())
            self.release(time.monotonic())


def _stop_with_parent() -> None:
    """SIGTERM this switch when the launcher dies, even by SIGKILL (Linux)."""
    pr_set_pdeathsig = 1
    ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGTERM)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="User-space netem switch (bridge namespace).")
    parser.add_argument("--ports", nargs="+", required=True)
    parser.add_argument("--delay-ms", type=float, default=0.0)
    parser.add_argument("--jitter-ms", type=float, default=0.0)
    parser.add_argument("--loss-percent", type=float, default=0.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--stats", type=Path)
    args = parser.parse_args(argv)
    _stop_with_parent()
    switch = NetemSwitch(
        args.ports, args.delay_ms / 1e3, args.jitter_ms / 1e3, args.loss_percent / 100, args.seed
    )
    stop: list[bool] = []

    def request_stop(signum: int, frame: object) -> None:
        stop.append(True)

    signal.signal(signal.SIGTERM, request_stop)
    signal.signal(signal.SIGINT, request_stop)
    print("netem switch ready", flush=True)
    switch.run(stop)
    if args.stats is not None:
        args.stats.write_text(json.dumps(vars(switch.counters)))
    sys.exit(0)


if __name__ == "__main__":
    main()
