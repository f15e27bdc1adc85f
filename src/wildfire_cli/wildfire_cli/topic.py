"""``wildfire topic list|echo|hz|info|pub``: inspect topics like ``ros2 topic``, no ROS needed.

Runs on the active backend (rclpy in a ROS 2 install, else Cyclone DDS on loopback), so it
sees the same graph as ``ros2 topic`` on a machine with rmw_cyclonedds_cpp.
"""

from __future__ import annotations

import itertools
import math
import sys
import time
from collections import deque
from typing import TYPE_CHECKING, Any

import yaml

from wildfire_cli.common import UserError, positive_float, positive_int
from wildfire_cli.ros_tools import (
    publisher_qos,
    ros_node,
    subscription_qos,
    wait_for_topic_type,
)

if TYPE_CHECKING:
    import argparse

DISCOVERY_S = 2.0
"""How long ``list`` listens for discovery before answering."""
INFO_DISCOVERY_S = 5.0
"""Longest ``info`` waits for its topic to be discovered."""
ENDPOINT_SETTLE_S = 0.3
"""Extra time ``info`` listens once its topic is known, for the other endpoints."""
GRAPH_SETTLE_S = 0.5
"""``list`` ends once no new topic has shown up for this long (after ``--spin-time``)."""
READER_MATCH_SETTLE_S = 0.5
"""How long ``pub`` lets a just-matched reader discover it before the first message."""


def add_parser(subparsers: Any) -> None:
    """Register ``wildfire topic`` and its sub-commands."""
    parser = subparsers.add_parser(
        "topic",
        help="inspect and publish ROS 2 topics (like ros2 topic)",
        description="Inspect and publish ROS 2 topics on the wildfire system's DDS domain.",
    )
    commands = parser.add_subparsers(dest="topic_command", metavar="VERB", required=True)

    listing = commands.add_parser("list", help="list topics in the graph")
    listing.add_argument("-t", "--show-types", action="store_true", help="also print types")
    listing.add_argument(
        "--spin-time",
        type=positive_float,
        default=DISCOVERY_S,
        help="seconds to wait for discovery (default %(default)s)",
    )
    listing.set_defaults(handler=run_list)

    echo = commands.add_parser("echo", help="print messages of a topic")
    echo.add_argument("topic", help="topic name, e.g. /wildfire/fire_map")
    echo.add_argument("type", nargs="?", help="message type (default: discovered)")
    echo.add_argument("--once", action="store_true", help="print one message and exit")
    echo.add_argument(
        "--timeout",
        type=positive_float,
        default=None,
        help="give up after this many seconds without a message",
    )
    echo.add_argument(
        "--full", action="store_true", help="print whole arrays (default: cut after 128 elements)"
    )
    echo.set_defaults(handler=run_echo)

    hz = commands.add_parser("hz", help="print the publishing rate of a topic")
    hz.add_argument("topic")
    hz.add_argument(
        "--window",
        "-w",
        type=positive_int,
        default=100,
        help="messages the statistics cover (default %(default)s)",
    )
    hz.add_argument(
        "--timeout", type=positive_float, default=None, help="stop after this many seconds"
    )
    hz.set_defaults(handler=run_hz)

    info = commands.add_parser("info", help="type and endpoint counts of a topic")
    info.add_argument("topic")
    info.add_argument("-v", "--verbose", action="store_true", help="list endpoints with QoS")
    info.add_argument(
        "--spin-time",
        type=positive_float,
        default=INFO_DISCOVERY_S,
        help="longest wait for the topic to be discovered (default %(default)s s)",
    )
    info.set_defaults(handler=run_info)

    pub = commands.add_parser("pub", help="publish a message given as YAML")
    pub.add_argument("topic")
    pub.add_argument("type", help="message type, e.g. std_msgs/msg/String")
    pub.add_argument("values", nargs="?", default="{}", help="field values as YAML")
    pub.add_argument(
        "-r",
        "--rate",
        type=positive_float,
        default=1.0,
        help="publications per second (default %(default)s)",
    )
    pub.add_argument(
        "-t", "--times", type=positive_int, default=None, help="publish this many times and exit"
    )
    pub.add_argument("-1", "--once", action="store_true", help="publish once and exit")
    pub.add_argument(
        "--wait-matching",
        type=positive_float,
        default=2.0,
        help="seconds to wait for a subscriber before the first message",
    )
    pub.set_defaults(handler=run_pub)


def _absolute(topic: str) -> str:
    if not topic.startswith("/"):
        topic = "/" + topic
    return topic


def run_list(args: argparse.Namespace) -> int:
    """``topic list``."""
    with ros_node("wildfire_topic_list") as node:
        # Listen at least --spin-time, and on while discovery still brings new topics.
        start = last_change = time.monotonic()
        known: set[str] = set()
        while True:
            now = time.monotonic()
            names = {name for name, _ in node.get_topic_names_and_types()}
            if names != known:
                known, last_change = names, now
            if now - start >= args.spin_time and now - last_change >= GRAPH_SETTLE_S:
                break
            if now - start >= 3 * args.spin_time:
                break
            time.sleep(0.05)
        for name, types in node.get_topic_names_and_types():
            print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def run_echo(args: argparse.Namespace) -> int:
    """``topic echo``."""
    from wildfire_ros.introspection import message_to_yaml
    from wildfire_ros.runtime import get_message, rclpy

    topic = _absolute(args.topic)
    msg_type = get_message(args.type) if args.type else None  # bad type: fail before DDS
    with ros_node("wildfire_topic_echo") as node:
        start = time.monotonic()
        if msg_type is None:
            type_name = wait_for_topic_type(node, topic, args.timeout)
            if type_name is None:
                raise UserError(
                    f"topic {topic}: not published within {args.timeout} s "
                    "(give its TYPE to wait for it anyway)"
                )
            msg_type = get_message(type_name)
        truncate = None if args.full else 128
        received = 0

        def echo_callback(msg: Any) -> None:
            nonlocal received, start
            received += 1
            start = time.monotonic()
            sys.stdout.write(message_to_yaml(msg, truncate) + "---\n")
            sys.stdout.flush()

        node.create_subscription(msg_type, topic, echo_callback, subscription_qos(node, topic))
        while rclpy.ok() and not (args.once and received):
            if args.timeout is not None and time.monotonic() - start > args.timeout:
                if received:
                    return 0
                print(
                    f"wildfire topic: no message on {topic} within {args.timeout} s",
                    file=sys.stderr,
                )
                return 1
            rclpy.spin_once(node, timeout_sec=0.1)
    return 0


def run_hz(args: argparse.Namespace) -> int:
    """``topic hz``: rate statistics printed every second."""
    from wildfire_ros.runtime import get_message, rclpy

    topic = _absolute(args.topic)
    with ros_node("wildfire_topic_hz") as node:
        type_name = wait_for_topic_type(node, topic, args.timeout)
        if type_name is None:
            raise UserError(f"topic {topic}: not published within {args.timeout} s")
        arrivals: deque[float] = deque(maxlen=args.window + 1)
        node.create_subscription(
            get_message(type_name),
            topic,
            lambda _data: arrivals.append(time.monotonic()),
            subscription_qos(node, topic),
            raw=True,
        )
        start = last_print = time.monotonic()
        printed = False
        while rclpy.ok():
            now = time.monotonic()
            if args.timeout is not None and now - start >= args.timeout:
                break
            if now - last_print >= 1.0:
                last_print = now
                line = format_rate(list(arrivals))
                print(line if line else "no new messages", flush=True)
                printed = printed or bool(line)
            rclpy.spin_once(node, timeout_sec=0.05)
    return 0 if printed or args.timeout is None else 1


def format_rate(arrivals: list[float]) -> str:
    """``ros2 topic hz`` style statistics of arrival times (empty with < 2 arrivals)."""
    if len(arrivals) < 2:
        return ""
    gaps = [b - a for a, b in itertools.pairwise(arrivals)]
    mean = sum(gaps) / len(gaps)
    std = math.sqrt(sum((g - mean) ** 2 for g in gaps) / len(gaps))
    return (
        f"average rate: {1.0 / mean:.3f}\n\tmin: {min(gaps):.3f}s max: {max(gaps):.3f}s "
        f"std dev: {std:.5f}s window: {len(gaps)}"
    )


def run_info(args: argparse.Namespace) -> int:
    """``topic info``."""
    from wildfire_ros.graph import endpoint_infos

    topic = _absolute(args.topic)
    with ros_node("wildfire_topic_info") as node:
        # Answer as soon as the topic is discovered (a loaded machine can take seconds),
        # then give the rest of its endpoints a moment to show up.
        if wait_for_topic_type(node, topic, args.spin_time) is not None:
            time.sleep(ENDPOINT_SETTLE_S)
        types = dict(node.get_topic_names_and_types()).get(topic)
        if not types:
            raise UserError(
                f"unknown topic {topic!r}: not in the graph (see 'wildfire topic list')"
            )
        print(f"Type: {', '.join(types)}")
        print(f"Publisher count: {node.count_publishers(topic)}")
        print(f"Subscription count: {node.count_subscribers(topic)}")
        if args.verbose:
            for endpoint in endpoint_infos(node, topic):
                print(
                    f"\nNode name: {endpoint.node}\nEndpoint type: {endpoint.kind}\n"
                    f"QoS profile:\n  Reliability: {endpoint.reliability}\n"
                    f"  History (Depth): {endpoint.history}\n  Durability: {endpoint.durability}"
                )
    return 0


def parse_values(text: str) -> Any:
    """The YAML field values of ``topic pub`` (a mapping, or empty)."""
    try:
        values = yaml.safe_load(text)
    except yaml.YAMLError as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else "syntax error"
        raise UserError(f"values {text!r}: malformed YAML ({first})") from None
    if values is None:
        return {}
    if not isinstance(values, dict):
        raise UserError(f'values {text!r}: expected a YAML mapping such as "{{data: hello}}"')
    return values


def run_pub(args: argparse.Namespace) -> int:
    """``topic pub``."""
    from wildfire_ros.introspection import set_message_fields
    from wildfire_ros.runtime import Duration, get_message, rclpy

    topic = _absolute(args.topic)
    msg_type = get_message(args.type)
    message = set_message_fields(msg_type(), parse_values(args.values))
    times = 1 if args.once else args.times
    with ros_node("wildfire_topic_pub") as node:
        publisher = node.create_publisher(msg_type, topic, publisher_qos(topic))
        end_wait = time.monotonic() + args.wait_matching
        while publisher.get_subscription_count() == 0 and time.monotonic() < end_wait:
            time.sleep(0.02)
        if publisher.get_subscription_count():
            # Our writer has matched a reader, but the reader may not have matched us yet, and
            # a volatile reader (Fast DDS) ignores samples written before it did.
            time.sleep(READER_MATCH_SETTLE_S)
        print("publisher: beginning loop", flush=True)
        count = 0
        period = 1.0 / args.rate
        next_time = time.monotonic()
        while rclpy.ok() and (times is None or count < times):
            count += 1
            publisher.publish(message)
            print(f"publishing #{count}: {message!r}\n", flush=True)
            next_time += period
            if times is not None and count >= times:
                break
            time.sleep(max(0.0, next_time - time.monotonic()))
        # Reliable delivery must finish before the writer goes away (a late reader is still
        # being served by retransmissions).
        publisher.wait_for_all_acked(Duration(seconds=args.wait_matching))
    return 0


__all__ = ["add_parser", "format_rate", "parse_values"]
