"""A hostile participant: floods every topic of a running system with bad and replayed messages.

``python -m wildfire_testbed.wire_fuzzer --aircraft 3 --rate 200 --duration 60`` joins the
domain like any node (``ROS_DOMAIN_ID``, the runtime's backend) and, cycling through
:data:`CASES`, publishes malformed messages (sizes, layouts, encodings), out-of-range ones
(non-finite numbers, values the model never produces, unknown reporters, wrong frames, stamps
far ahead) on every topic the nodes subscribe to, with each topic's own QoS so that every
reader matches. It also records what the system publishes and replays it a second later.

A robust system finishes the episode as if the fuzzer were absent (lockstep runs still equal
``wildfire eval``) and counts every drop in its ``/diagnostics`` input-validation statuses.
``/clock`` is left alone: rclpy's time source consumes it inside the client library, out of
the nodes' reach (see ``docs/deployment.md``, "Security").
"""

from __future__ import annotations

import argparse
import collections
import functools
import math
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from wildfire_msgs_py import belief_delta, codecs, contract, grid_tiles, radio_codec, system_codecs
from wildfire_msgs_py.stop_signals import interrupt_on_stop_signals
from wildfire_ros.node_support import contract_publisher, contract_subscription
from wildfire_ros.runtime import Node, SingleThreadedExecutor, rclpy

TICK_NS = contract.DECISION_PERIOD_NS
FAR_FUTURE_NS = 10**15
"""A stamp no episode reaches (11 days)."""
REPLAY_DELAY_S = 1.0


@dataclass(frozen=True)
class Case:
    """One kind of bad message on one topic."""

    name: str
    spec: contract.TopicSpec
    build: Callable[[int], Any]
    """Message for aircraft ``k`` (ignored on shared topics)."""


def _bad_length_grid(_: int) -> Any:
    msg = codecs.fire_grid_to_msg(np.zeros((100, 100), dtype=bool), TICK_NS)
    msg.data = msg.data[:9]
    return msg


def _small_grid(_: int) -> Any:
    return codecs.fire_grid_to_msg(np.ones((30, 30), dtype=bool), 0)


def _odd_values_grid(_: int) -> Any:
    return codecs.grid_to_msg(np.full((100, 100), 37, dtype=np.int8), 0)


def _over_100_percent_grid(_: int) -> Any:
    # A belief is a percentage (0..100); a fire map only 0 or 100.
    return codecs.grid_to_msg(np.full((100, 100), 120, dtype=np.int8), 0)


def _wrong_frame_grid(_: int) -> Any:
    return codecs.grid_to_msg(np.full((100, 100), 100, dtype=np.int8), 0, frame_id="odom")


def _future_grid(_: int) -> Any:
    return codecs.fire_grid_to_msg(np.ones((100, 100), dtype=bool), FAR_FUTURE_NS)


def _nan_ages(_: int) -> Any:
    return system_codecs.age_image_to_msg(np.full((100, 100), np.nan, dtype=np.float32), 0)


def _bad_encoding_ages(_: int) -> Any:
    msg = system_codecs.age_image_to_msg(np.zeros((100, 100), dtype=np.float32), 0)
    msg.encoding = "mono8"
    return msg


def _state(values: list[float], stamp: int = TICK_NS) -> Callable[[int], Any]:
    return lambda _: system_codecs.stamped_state_to_msg(np.array(values, dtype=float), stamp)


def _short_state(_: int) -> Any:
    msg = system_codecs.stamped_state_to_msg(np.zeros(4), TICK_NS)
    msg.position = msg.position[:2]
    return msg


def _visit(row0: int, col0: int, side: int, stamp: int = TICK_NS) -> Callable[[int], Any]:
    cells = np.ones((side, side), dtype=bool)
    return lambda _: codecs.visit_to_msg(codecs.VisitWindow(row0, col0, cells, cells), stamp)


def _episode(phase: str, values: dict[str, Any]) -> Callable[[int], Any]:
    def build(_: int) -> Any:
        msg = system_codecs.episode_to_msg("running", values)
        msg.message = phase
        return msg

    return build


def _ack(reporter: Callable[[int], str], stamp: int) -> Callable[[int], Any]:
    return lambda k: system_codecs.ack_to_msg(reporter(k), stamp)


def _snapshot_nan(_: int) -> Any:
    snapshot = system_codecs.BeliefSnapshot(
        math.nan, 5.0, np.zeros((100, 100), bool), np.zeros((100, 100), np.float32)
    )
    return system_codecs.snapshot_to_msg(snapshot)


def _odometry_nan(k: int) -> Any:
    return codecs.pose_to_odometry((math.nan, 0.0, 0.0, 0.0), k, TICK_NS)


def _garbled_diagnostics(_: int) -> Any:
    status = codecs.NodeStatus(
        f"uav0/agent: {contract.DEADLINE_STATUS}", "uav0", "OK", "garbage", {"decisions": "many"}
    )
    return codecs.diagnostics_to_msg([status], 0)


def _radio(**changes: Any) -> Callable[[int], Any]:
    """A radio message of aircraft ``k`` at (500, 500), tick 1, with ``changes`` (an
    ``aircraft`` change is relative: the message then claims another aircraft's index)."""

    def build(k: int) -> Any:
        message = radio_codec.RadioMessage(1, k, 500.0, 500.0, 0.0, 0, np.zeros(40, np.uint8))
        fields = dict(changes)
        message = message._replace(aircraft=k + fields.pop("aircraft", 0), **fields)
        return radio_codec.radio_to_msg(message)

    return build


def _radio_bytes(data: bytes) -> Callable[[int], Any]:
    def build(_: int) -> Any:
        msg = radio_codec.radio_to_msg(
            radio_codec.RadioMessage(1, 0, 0.0, 0.0, 0.0, 0, np.zeros(0, np.uint8))
        )
        msg.data = data
        return msg

    return build


def _radio_bomb(k: int) -> Any:
    """A catch-up reply whose payload does not inflate to what it claims."""
    msg = _radio()(k)
    header = bytes(msg.data[: radio_codec.HEADER.size - 1])
    reply = bytes([0x01, 0, 0x10, 0x27, 4, 0]) + b"\x78\x9c\x03\x00"  # 10 000 cells, empty
    msg.data = header + reply + bytes(msg.data[radio_codec.HEADER.size :])
    return msg


def _delta(cells: list[int], words: slice | None = None) -> Callable[[int], Any]:
    def build(_: int) -> Any:
        n = len(cells)
        delta = belief_delta.BeliefDelta(
            3 * TICK_NS, 0, 3, np.array(cells), np.zeros(n, np.int64), np.zeros(n, np.int32)
        )
        msg = belief_delta.delta_to_msg(delta)
        if words is not None:
            msg.data = msg.data[words]
        return msg

    return build


def _off_grid_tile(_: int) -> Any:
    tile = grid_tiles.Tile(TICK_NS, 5, 7, np.zeros((grid_tiles.TILE, grid_tiles.TILE), np.int8))
    return grid_tiles.tile_to_msg(tile)


C = contract
CASES: tuple[Case, ...] = (
    Case("fire map: data length", C.FIRE_MAP, _bad_length_grid),
    Case("fire map: 30 x 30", C.FIRE_MAP, _small_grid),
    Case("fire map: values", C.FIRE_MAP, _odd_values_grid),
    Case("fire map: frame", C.FIRE_MAP, _wrong_frame_grid),
    Case("fire map: future", C.FIRE_MAP, _future_grid),
    Case("fuel map: data length", C.FUEL_MAP, _bad_length_grid),
    Case("belief: data length", C.BELIEF, _bad_length_grid),
    Case("belief: values", C.BELIEF, _over_100_percent_grid),
    Case("belief age: data length", C.BELIEF_AGE, _bad_length_grid),
    Case("exact ages: NaN", C.BELIEF_AGE_EXACT, _nan_ages),
    Case("exact ages: encoding", C.BELIEF_AGE_EXACT, _bad_encoding_ages),
    Case("belief delta: cells off the map", C.BELIEF_DELTA, _delta([5, 10**7])),
    Case("belief delta: truncated", C.BELIEF_DELTA, _delta([5, 6], slice(0, -1))),
    Case("fuel tile: off the tile grid", C.FUEL_TILES, _off_grid_tile),
    Case("score: NaN", C.SCORE, lambda _: codecs.score_to_msg(math.nan)),
    Case("score: negative", C.SCORE, lambda _: codecs.score_to_msg(-1e9)),
    Case("state: NaN", C.STATE_STAMPED, _state([math.nan, 0, 0, 0])),
    Case("state: 1000 km away", C.STATE_STAMPED, _state([1e6, 1e6, 0, 0])),
    Case("state: bank 80 deg", C.STATE_STAMPED, _state([500, 500, 0, 1.4])),
    Case("state: two values", C.STATE_STAMPED, _short_state),
    Case("state: future", C.STATE_STAMPED, _state([500, 500, 0, 0], FAR_FUTURE_NS)),
    Case("state: between ticks", C.STATE_STAMPED, _state([500, 500, 0, 0], TICK_NS + 1)),
    Case("visit: 5 x 5", C.VISIT, _visit(40, 40, 5)),
    Case("visit: off the map", C.VISIT, _visit(5_000, -7_000, 21)),
    Case("visit: future", C.VISIT, _visit(40, 40, 21, FAR_FUTURE_NS)),
    Case("visit: cells off the map", C.VISIT, _visit(-15, 40, 21)),
    Case("camera: visit-sized window", C.CAMERA_CELLS[0], _visit(40, 40, 21)),
    Case("camera: cells off the map", C.CAMERA_CELLS[3], _visit(40, 80, 61)),
    Case("episode: phase", C.EPISODE, _episode("exploded", {"tick": 3})),
    Case("episode: tick text", C.EPISODE, _episode("running", {"tick": "soon"})),
    Case("episode: tick far ahead", C.EPISODE, _episode("running", {"tick": 10**9})),
    Case("ack: stranger", C.ACK, _ack(lambda _: "intruder", TICK_NS)),
    Case("ack: future", C.ACK, _ack(lambda k: f"uav{k}", FAR_FUTURE_NS)),
    Case("ack: aggregator future", C.ACK, _ack(lambda _: "belief_aggregator", FAR_FUTURE_NS)),
    Case("snapshot: NaN", C.BELIEF_SNAPSHOT, _snapshot_nan),
    Case("snapshot: short", C.BELIEF_SNAPSHOT, lambda _: codecs.state_to_msg(np.zeros(4))),
    Case("request: flood", C.BELIEF_REQUEST, _ack(lambda _: "intruder", TICK_NS)),
    Case("odom: NaN", C.ODOM, _odometry_nan),
    Case("bank: NaN", C.BANK_CMD, lambda _: codecs.bank_cmd_to_msg(math.nan)),
    Case("state array: NaN", C.STATE, lambda _: codecs.state_to_msg((math.nan,) * 4)),
    Case("diagnostics: garbled", C.DIAGNOSTICS, _garbled_diagnostics),
    Case("radio: another aircraft", C.RADIO, _radio(aircraft=1)),
    Case("radio: NaN pose", C.RADIO, _radio(x_m=math.nan)),
    Case("radio: future", C.RADIO, _radio(tick=10**9)),
    Case("radio: bits for another window", C.RADIO, _radio(bits=np.zeros(7, np.uint8))),
    Case("radio: truncated", C.RADIO, _radio_bytes(b"\x01\x00\x00")),
    Case("radio: reply bomb", C.RADIO, _radio_bomb),
)
"""Every bad message the fuzzer sends, each of its topic's own type."""


class WireFuzzer(Node):
    """Publishes :data:`CASES` round robin at ``rate_hz`` and replays what the system sends."""

    def __init__(self, n_aircraft: int, rate_hz: float, replay: bool = True) -> None:
        super().__init__("wire_fuzzer")
        self.n = n_aircraft
        self.sent: collections.Counter[str] = collections.Counter()
        self.replayed = 0
        self.writers: dict[str, Any] = {}
        self.replay_queue: collections.deque[tuple[float, str, Any]] = collections.deque()
        self.next_case = 0
        for spec in contract.TOPICS + contract.SYSTEM_TOPICS:
            if spec is contract.CLOCK:
                continue
            for k in range(n_aircraft) if spec.per_aircraft else [None]:
                name = spec.resolve(k)
                self.writers[name] = contract_publisher(self, spec, k)
                if replay:
                    remember = functools.partial(self._remember, name)
                    contract_subscription(self, spec, remember, aircraft=k)
        self.timer = self.create_timer(1.0 / rate_hz, self._tick)

    def _remember(self, topic: str, msg: Any) -> None:
        if len(self.replay_queue) < 1_000:
            self.replay_queue.append((time.monotonic() + REPLAY_DELAY_S, topic, msg))

    def _tick(self) -> None:
        case = CASES[self.next_case % len(CASES)]
        k = (self.next_case // len(CASES)) % self.n
        self.next_case += 1
        topic = case.spec.resolve(k if case.spec.per_aircraft else None)
        self.writers[topic].publish(case.build(k))
        self.sent[case.name] += 1
        # One replay per bad message: our own messages come back too, so replaying all that
        # arrives would grow without bound.
        if self.replay_queue and self.replay_queue[0][0] <= time.monotonic():
            _, topic, msg = self.replay_queue.popleft()
            self.writers[topic].publish(msg)
            self.replayed += 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wildfire_testbed.wire_fuzzer")
    parser.add_argument("--aircraft", type=int, default=3, help="aircraft of the target system")
    parser.add_argument("--rate", type=float, default=200.0, help="bad messages per second")
    parser.add_argument("--duration", type=float, default=60.0, help="seconds to run")
    parser.add_argument("--no-replay", action="store_true", help="only send bad messages")
    args = parser.parse_args(argv)
    if args.aircraft < 1 or args.rate <= 0 or args.duration <= 0:
        parser.error("--aircraft, --rate and --duration must be positive")
    interrupt_on_stop_signals()  # SIGTERM ends the flood like Ctrl-C, with the tally
    rclpy.init(args=[])
    node = WireFuzzer(args.aircraft, args.rate, replay=not args.no_replay)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    end = time.monotonic() + args.duration
    try:
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    except KeyboardInterrupt:
        pass
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not cut clean-up
        print(
            f"wire_fuzzer: sent {sum(node.sent.values())} bad messages "
            f"({len(node.sent)} kinds), replayed {node.replayed}",
            file=sys.stderr,
        )
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
