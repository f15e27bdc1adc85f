"""The ``wildfire`` command-line tool.

Every sub-command lives in its own module of this package and exposes two functions:
``add_parser(subparsers)`` builds its argparse parser and sets ``handler`` to a function
``(args) -> int`` returning the exit status. User mistakes are raised as :class:`UserError`
(or one of the project's error classes listed in ``USER_ERRORS``) and reported as one line
``wildfire <command>: error: <message>`` with exit status 2, never as a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from typing import TYPE_CHECKING

from wildfire_cli.common import USER_ERRORS, ArgumentParser
from wildfire_msgs_py.stop_signals import stopped

if TYPE_CHECKING:
    from collections.abc import Sequence

# Sub-command modules, in the order ``wildfire --help`` lists them.
COMMAND_MODULES = (
    "run",
    "eval",
    "train",
    "ensemble",
    "fire",
    "sensor",
    "bench",
    "topic",
    "bag",
    "report",
)


def build_parser(only: str | None = None) -> ArgumentParser:
    """Build the top-level parser with every available sub-command (or just ``only``).

    Each command module imports what its command needs (torch, the training package, ...):
    ``wildfire topic list`` must not pay for ``wildfire train``'s imports, so a command line
    naming a command builds that command's parser alone.
    """
    parser = ArgumentParser(
        prog="wildfire",
        description="Decentralized wildfire surveillance with autonomous aircraft "
        "(ROS 2 + deep RL).",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES if only not in COMMAND_MODULES else (only,):
        try:
            module = importlib.import_module(f"wildfire_cli.{name}")
        except ModuleNotFoundError as error:
            # A command whose module is not written yet is simply not offered.
            if error.name == f"wildfire_cli.{name}":
                continue
            raise
        module.add_parser(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``.venv/bin/wildfire``."""
    # One intra-op thread per process unless the user asks otherwise (before torch loads):
    # the batched kernels here are small, the system runs many processes on few cores, and
    # OpenMP's spinning worker threads slow a loaded machine down by up to 20x (measured:
    # the fire benchmark at batch 16 ran at 1 000 instead of 20 000 env-steps/s with two
    # threads next to a training job). Child processes (nodes) inherit the setting.
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    words = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(words[0] if words else None)
    args = parser.parse_args(words)
    # What was typed, beside the defaults: a parameters file yields to the one, not the other.
    args.argv = words
    try:
        return int(args.handler(args) or 0)
    except USER_ERRORS as error:
        print(f"wildfire {args.command}: error: {error}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, SystemError) as error:
        if not stopped(error):
            raise
        print(f"wildfire {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # `wildfire topic echo ... | head` closes our stdout early: not an error.
        return 0


if __name__ == "__main__":
    sys.exit(main())


__all__ = ["argparse", "build_parser", "main"]
