"""``wildfire bag record|play|info|convert|reindex``: rosbag2 (MCAP) bags of the system's topics."""

from __future__ import annotations

import argparse
import datetime as dt
import signal
import sys
import time
from typing import TYPE_CHECKING, Any

from wildfire_cli.common import UserError, positive_float, print_json

if TYPE_CHECKING:
    from wildfire_ros.bag import BagInfo


def _non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected seconds >= 0, got {text}")
    return value


def _topic_name(text: str) -> str:
    return text if text.startswith("/") else "/" + text


def add_parser(subparsers: Any) -> None:
    """Register ``wildfire bag``."""
    from wildfire_ros.bag import BULKY_TOPICS
    from wildfire_ros.mcap_writer import DEFAULT_PRESET, PRESETS

    parser = subparsers.add_parser(
        "bag",
        help="record, play and inspect rosbag2 (MCAP) bags",
        description="Record topics to a rosbag2 MCAP directory, play one back onto its "
        "topics, summarize, re-compress or repair one.",
    )
    commands = parser.add_subparsers(dest="bag_command", metavar="VERB", required=True)
    compression_help = (
        f"chunk compression preset: {', '.join(PRESETS)} (default {DEFAULT_PRESET}: zstd level "
        "1; zstd_small: level 19, 4 MiB chunks)"
    )

    record = commands.add_parser("record", help="record topics until Ctrl-C")
    record.add_argument("-o", "--output", required=True, help="new bag directory to create")
    record.add_argument(
        "-a",
        "--all",
        action="store_true",
        help="record every topic, also those appearing later, except the bulky system topics "
        f"({', '.join(BULKY_TOPICS)}) unless named with --include",
    )
    record.add_argument("topics", nargs="*", help="topics to record")
    record.add_argument(
        "-x", "--exclude", nargs="+", default=[], metavar="TOPIC", help="with -a: leave out"
    )
    record.add_argument(
        "--include", nargs="+", default=[], metavar="TOPIC", help="with -a: record bulky topics"
    )
    record.add_argument(
        "--compression", default=DEFAULT_PRESET, choices=PRESETS, help=compression_help
    )
    record.add_argument(
        "--use-sim-time",
        action="store_true",
        help="log times from /clock (zero before the first one), as ros2 bag record does",
    )
    record.add_argument(
        "--duration", type=positive_float, default=None, help="stop after this many seconds"
    )
    record.set_defaults(handler=run_record)

    play = commands.add_parser("play", help="publish a bag's messages on their topics")
    play.add_argument("bag", help="bag directory")
    play.add_argument("-r", "--rate", type=positive_float, default=1.0, help="speed factor")
    play.add_argument("-l", "--loop", action="store_true", help="play again and again")
    play.add_argument("--topics", nargs="+", metavar="TOPIC", help="play only these topics")
    play.add_argument(
        "--start-offset",
        type=_non_negative_float,
        default=0.0,
        metavar="S",
        help="start S seconds into the bag",
    )
    play.add_argument(
        "--delay",
        type=_non_negative_float,
        default=1.0,
        metavar="S",
        help="wait S seconds after creating the publishers, for subscribers to find them "
        "(default 1)",
    )
    play.add_argument(
        "--wait-for-subscribers",
        action="store_true",
        help="before playing, wait until every played topic has a subscriber (then --delay)",
    )
    play.add_argument("--json", action="store_true", help="print a JSON summary")
    play.set_defaults(handler=run_play)

    info = commands.add_parser("info", help="summarize a bag")
    info.add_argument("bag", help="bag directory")
    info.add_argument("--json", action="store_true", help="print a JSON summary")
    info.set_defaults(handler=run_info)

    convert = commands.add_parser("convert", help="copy a bag with another compression")
    convert.add_argument("input", help="bag directory to read")
    convert.add_argument("output", help="new bag directory to write")
    convert.add_argument(
        "--compression", default=DEFAULT_PRESET, choices=PRESETS, help=compression_help
    )
    convert.add_argument("--json", action="store_true", help="print a JSON summary")
    convert.set_defaults(handler=run_convert)

    reindex = commands.add_parser(
        "reindex", help="recover a truncated recording (recorder killed) and its metadata.yaml"
    )
    reindex.add_argument("bag", help="bag directory")
    reindex.add_argument("--json", action="store_true", help="print a JSON summary")
    reindex.set_defaults(handler=run_reindex)


def run_record(args: argparse.Namespace) -> int:
    """``bag record``: finalizes the bag on Ctrl-C, SIGTERM or ``--duration``."""
    from wildfire_msgs_py.stop_signals import interrupt_on_stop_signals
    from wildfire_ros.bag import BULKY_TOPICS, BagRecorder
    from wildfire_ros.runtime import rclpy

    if args.all == bool(args.topics):
        raise UserError("give either -a/--all or one or more topics")
    if (args.exclude or args.include) and not args.all:
        raise UserError("--exclude and --include go with -a/--all")
    topics = None if args.all else [_topic_name(t) for t in args.topics]
    include = {_topic_name(t) for t in args.include}
    exclude = {t for t in BULKY_TOPICS if t not in include} | {_topic_name(t) for t in args.exclude}
    interrupt_on_stop_signals()
    rclpy.init(args=[])
    recorder = None
    try:
        recorder = BagRecorder(
            args.output,
            topics,
            exclude=exclude,
            compression=args.compression,
            use_sim_time=args.use_sim_time,
        )
        what = "all topics" if topics is None else ", ".join(topics)
        print(
            f"Recording to {args.output} ({what}; {args.compression})", file=sys.stderr, flush=True
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


def run_play(args: argparse.Namespace) -> int:
    """``bag play``: Ctrl-C stops it cleanly (exit status 0, as ros2 bag play)."""
    from wildfire_cli.progress import progress_bar
    from wildfire_msgs_py.stop_signals import interrupt_on_stop_signals
    from wildfire_ros.bag_play import BagPlayer
    from wildfire_ros.runtime import rclpy

    topics = None if args.topics is None else [_topic_name(t) for t in args.topics]
    interrupt_on_stop_signals()
    rclpy.init(args=[])
    player = None
    try:
        player = BagPlayer(
            args.bag,
            topics=topics,
            rate=args.rate,
            start_offset_s=args.start_offset,
            loop=args.loop,
        )
        print(
            f"Playing {args.bag}: {player.message_count} messages on {len(player.topics)} "
            f"topics at rate {args.rate:g}{' in a loop' if args.loop else ''}",
            file=sys.stderr,
            flush=True,
        )
        stats = None
        try:
            if args.wait_for_subscribers:
                player.wait_for_subscribers()
            player.wait(args.delay)
            total = player.message_count
            with progress_bar("play", total, enabled=not args.json and not args.loop) as update:
                stats = player.play(update)
        except KeyboardInterrupt:
            pass
        stats = stats or player.stats
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        if player is not None:
            player.close()
        rclpy.try_shutdown()
    how = "stopped" if stats.interrupted else "played"
    print(f"{how.capitalize()}: {stats.published} messages", file=sys.stderr, flush=True)
    if args.json:
        print_json(
            {"published": stats.published, "loops": stats.loops, "interrupted": stats.interrupted}
        )
    return 0


def run_convert(args: argparse.Namespace) -> int:
    """``bag convert IN OUT``."""
    from wildfire_ros.bag import bag_info
    from wildfire_ros.bag_repair import convert

    before = bag_info(args.input, sizes=False)
    result = convert(args.input, args.output, args.compression)
    after = bag_info(result.path, sizes=False)
    summary = {
        "input": args.input,
        "output": args.output,
        "messages": result.messages,
        "input_bytes": before.size_bytes,
        "output_bytes": after.size_bytes,
        "compression": args.compression,
    }
    if args.json:
        print_json(summary)
    else:
        print(
            f"Wrote {result.messages} messages to {args.output} ({args.compression}): "
            f"{before.size_bytes / 1024:.1f} KiB -> {after.size_bytes / 1024:.1f} KiB"
        )
    return 0


def run_reindex(args: argparse.Namespace) -> int:
    """``bag reindex DIR``."""
    from wildfire_ros.bag_repair import reindex

    result = reindex(args.bag)
    summary = {
        "bag": args.bag,
        "messages": result.messages,
        "topics": result.topics,
        "complete": result.complete,
        "kept_original": None if result.kept_original is None else str(result.kept_original),
    }
    if args.json:
        print_json(summary)
    else:
        state = "complete" if result.complete else "truncated"
        print(
            f"Recovered {result.messages} messages on {result.topics} topics from the "
            f"{state} file; original kept as {result.kept_original}"
        )
    return 0


def _format_time(ns: int) -> str:
    stamp = dt.datetime.fromtimestamp(ns / 1e9, tz=dt.UTC)
    return f"{stamp:%b %d %Y %H:%M:%S.%f} ({ns / 1e9:.9f})"


def _info_json(info: BagInfo) -> dict[str, Any]:
    return {
        "path": str(info.path),
        "storage": info.storage,
        "size_bytes": info.size_bytes,
        "duration_s": info.duration_s,
        "start_ns": info.start_ns,
        "end_ns": info.end_ns,
        "message_count": info.message_count,
        "ros_distro": info.ros_distro,
        "time_source": info.time_source,
        "compression": info.compression,
        "compression_preset": info.preset,
        "chunk_bytes": info.chunk_bytes,
        "uncompressed_chunk_bytes": info.uncompressed_chunk_bytes,
        "compression_ratio": info.compression_ratio,
        "topics": [
            {
                "name": t.name,
                "type": t.type,
                "message_count": t.message_count,
                "size_bytes": t.size_bytes,
                "type_hash": t.type_hash,
                "offered_qos": [
                    {"reliable": q.reliable, "transient_local": q.transient_local, "depth": q.depth}
                    for q in t.offered_qos
                ],
            }
            for t in info.topics
        ],
    }


def run_info(args: argparse.Namespace) -> int:
    """``bag info``."""
    from wildfire_ros.bag import bag_info

    info = bag_info(args.bag)
    if args.json:
        print_json(_info_json(info))
        return 0
    files = ", ".join(sorted(p.name for p in info.path.glob("*.mcap")))
    compression = info.compression or "none"
    if info.compression:
        compression += f" ({info.preset or 'chunks'}, ratio {info.compression_ratio:.1f})"
    clock = f" ({info.time_source} time)" if info.time_source else ""
    print(f"Files:             {files}")
    print(f"Bag size:          {info.size_bytes / 1024:.1f} KiB")
    print(f"Storage id:        {info.storage}")
    print(f"ROS Distro:        {info.ros_distro or 'unknown'}")
    print(f"Compression:       {compression}")
    print(f"Duration:          {info.duration_s:.3f}s{clock}")
    print(f"Start:             {_format_time(info.start_ns)}")
    print(f"End:               {_format_time(info.end_ns)}")
    print(f"Messages:          {info.message_count}")
    for i, topic in enumerate(info.topics):
        label = "Topic information: " if i == 0 else " " * 19
        print(
            f"{label}Topic: {topic.name} | Type: {topic.type} | Count: {topic.message_count} "
            f"| Size: {topic.size_bytes / 1024:.1f} KiB | Serialization Format: cdr"
        )
    return 0


__all__ = ["add_parser"]
