"""``wildfire ensemble``: one policy file from several trained networks (mean Q-values),
flown against each of them on the validation seeds."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from wildfire_cli.common import (
    add_parallel_arguments,
    non_negative_int,
    positive_int,
    print_json,
)
from wildfire_sim.shapes import Shape


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "ensemble",
        help="combine trained networks into one policy (the mean of their Q-values)",
        description="Write one TorchScript policy whose Q-values are the mean of the members' "
        "(policy files of one approach and image shape, e.g. two training seeds, or a network "
        "and its fine-tune), then fly it and each member on the same validation seeds and "
        "record in its card what it gains over each, paired, per fire shape. Its card names "
        "every member by hash, with its own card. It flies wherever one network does (eval, "
        "report, the agent node).",
    )
    parser.add_argument("members", nargs="+", type=Path, metavar="POLICY.pt")
    parser.add_argument("--out", type=Path, required=True, metavar="FILE", help="policy file")
    parser.add_argument(
        "--episodes",
        type=non_negative_int,
        default=100,
        metavar="K",
        help="validation episodes per fire shape (seeds 1000000..; default 100: networks this "
        "close need that many to tell apart; 0 skips the comparison)",
    )
    parser.add_argument(
        "--shapes",
        nargs="+",
        default=["circular"],
        metavar="SHAPE",
        help="fire shapes to validate on: circular, t, arc (default circular)",
    )
    parser.add_argument("--aircraft", type=positive_int, default=2, metavar="N")
    add_parallel_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from wildfire_learning.ensemble import ensemble_policy, validate

    shapes = [Shape.parse(name).value for name in args.shapes]  # a bad name fails first
    out = ensemble_policy(list(args.members), args.out)
    summary: dict[str, Any] = {"out": str(out), "members": [str(p) for p in args.members]}
    by_shape: dict[str, Any] = {}
    if args.episodes:
        summary["selection"] = validate(
            out, args.members, shapes, args.episodes, args.aircraft, args.workers, args.ray
        )
        by_shape = summary["selection"]["by_shape"]
    if args.json:
        print_json(summary)
        return 0
    print(f"ensemble of {len(args.members)} networks -> {out}")
    for shape, result in by_shape.items():
        print(f"  {shape}: {result['score_mean']:.1f} +- {result['score_sem']:.1f}")
        for name, member in result["members"].items():
            print(
                f"    vs {name} ({member['score_mean']:.1f}): {member['paired_gain']:+.1f} "
                f"+- {member['paired_gain_sem']:.1f} (better on {member['wins']} of "
                f"{args.episodes})"
            )
    return 0
