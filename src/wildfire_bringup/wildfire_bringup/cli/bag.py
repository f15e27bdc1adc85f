"""``wildfire bag record|info``: rosbag2 (MCAP) recordings of the system's topics."""

from __future__ import annotations

import datetime as dt
import signal
import sys
import time
from typing import TYPE_CHECKING, Any

from wildfire_bringup.cli.common import UserError, positive_float, print_json

if TYPE_CHECKING:
    import argparse


def add_parser(subparsers: Any) -> None:
    """Register ``wildfire bag``."""
    parser = subparsers.add_parser(
        "bag",
        help="record and inspect rosbag2 (MCAP) bags",
        description="Record topics to a rosbag2 MCAP directory, or summarize one.",
    )
    commands = parser.add_subparsers(dest="bag_command", metavar="VERB", required=True)
    record = commands.add_parser("record", help="record topics until Ctrl-C")
    record.add_argument("-o", "--output", required=True, help="new bag directory to create")
    record.add_argument(
        "-a", "--all", action="store_true", help="record every topic, also those appearing later"
    )
    record.add_argument("topics", nargs="*", help="topics to record")
    record.add_argument(
        "--duration", type=positive_float, default=None, help="stop after this many seconds"
    )
    record.set_defaults(handler=run_record)

    info = commands.add_parser("info", help="summarize a bag")
    info.add_argument("bag", help="bag directory")
    info.add_argument("--json", action="store_true", help="print a JSON summary")
    info.set_defaults(handler=run_info)


def run_record(args: argparse.Namespace) -> int:
    """``bag record``: finalizes the bag on Ctrl-C, SIGTERM or ``--duration``."""
    from wildfire_msgs_py.bag import BagRecorder
    from wildfire_msgs_py.node_support import interrupt_on_stop_signals
    from wildfire_msgs_py.runtime import rclpy

    if args.all == bool(args.topics):
        raise UserError("give either -a/--all or one or more topics")
    topics = None if args.all else [t if t.startswith("/") else "/" + t for t in args.topics]
    interrupt_on_stop_signals()
    rclpy.init(args=[])
    recorder = None
    try:
        recorder = BagRecorder(args.output, topics)
        print(
            f"Recording to {args.output} ({'all topics' if topics is None else ', '.join(topics)})",
            file=sys.stderr,
            flush=True,
        )
        end = None if args.duration is None else time.monotonic() + args.duration
        try:
            while rclpy.ok() and (end is None or time.monotonic() < end):
                rclpy.spin_once(recorder.node, timeout_sec=0.1)
        except KeyboardInterrupt:
            pass
    finally:
        # Ignore further Ctrl-C while the MCAP summary and metadata.yaml are written.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        if recorder is not None:
            recorder.close()
            print(
                f"Recorded {recorder.message_count} messages to {args.output}",
                file=sys.stderr,
                flush=True,
            )
        rclpy.try_shutdown()
    return 0


def _format_time(ns: int) -> str:
    stamp = dt.datetime.fromtimestamp(ns / 1e9, tz=dt.UTC)
    return f"{stamp:%b %d %Y %H:%M:%S.%f} ({ns / 1e9:.9f})"


def run_info(args: argparse.Namespace) -> int:
    """``bag info``."""
    from wildfire_msgs_py.bag import bag_info

    info = bag_info(args.bag)
    if args.json:
        print_json(
            {
                "path": str(info.path),
                "storage": info.storage,
                "size_bytes": info.size_bytes,
                "duration_s": info.duration_s,
                "start_ns": info.start_ns,
                "end_ns": info.end_ns,
                "message_count": info.message_count,
                "topics": [
                    {"name": t.name, "type": t.type, "message_count": t.message_count}
                    for t in info.topics
                ],
            }
        )
        return 0
    files = ", ".join(sorted(p.name for p in info.path.glob("*.mcap")))
    print(f"Files:             {files}")
    print(f"Bag size:          {info.size_bytes / 1024:.1f} KiB")
    print(f"Storage id:        {info.storage}")
    print(f"Duration:          {info.duration_s:.3f}s")
    print(f"Start:             {_format_time(info.start_ns)}")
    print(f"End:               {_format_time(info.end_ns)}")
    print(f"Messages:          {info.message_count}")
    for i, topic in enumerate(info.topics):
        label = "Topic information: " if i == 0 else " " * 19
        print(
            f"{label}Topic: {topic.name} | Type: {topic.type} | Count: {topic.message_count} "
            "| Serialization Format: cdr"
        )
    return 0


__all__ = ["add_parser"]
