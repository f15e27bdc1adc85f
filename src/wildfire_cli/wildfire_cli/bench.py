"""``wildfire bench``: measure the real system's speed (targets live here, not in tests)."""

from __future__ import annotations

import argparse
import importlib
import platform
import resource
import time
from typing import Any

import torch

from wildfire_cli.common import UserError, add_device_argument, map_size, print_json

# name -> (module, function, what it measures); the modules import lazily so a missing
# optional part (e.g. no trained model yet) only skips its own figures.
SUITES: dict[str, tuple[str, str, str]] = {
    "fire": ("wildfire_bench.core", "bench_fire", "batched fire model vs reference"),
    "env": ("wildfire_bench.core", "bench_env", "environment decisions per second"),
    "rh": ("wildfire_bench.core", "bench_receding_horizon", "receding-horizon planning"),
    "inference": ("wildfire_bench.inference", "bench_inference", "policy inference"),
    "dds": ("wildfire_bench.dds", "bench_dds", "DDS grid fan-out and overhead"),
    "system": ("wildfire_bench.system", "bench_system", "distributed system"),
    "network": (
        "wildfire_bench.network",
        "bench_network",
        "virtual hosts: latency per hop, recovery after a partition (root)",
    ),
}
QUICK_CAPABLE = {"inference", "dds", "system", "network"}
"""Suites that take ``quick`` and ``smoke`` themselves; the others get sizes below."""
SIZES: dict[str, dict[str, dict[str, Any]]] = {
    "quick": {
        "fire": {"steps": 40},
        "env": {"decisions": 100},
        "rh": {"decisions": 50, "plan_decisions": 100},
    },
    "smoke": {
        "fire": {"steps": 4, "batch_sizes": (16,)},
        "env": {"decisions": 5, "batch_sizes": (8,)},
        "rh": {"decisions": 10, "plan_decisions": 10},
    },
}
"""Sizes of the suites that take them as numbers, for ``--quick`` and ``--smoke``."""
DEVICE_CAPABLE = {"inference"}
"""Suites that time networks and so take ``--device``."""
MAP_CAPABLE = {"fire", "env"}
"""Suites with field-world figures, whose map ``--map-size`` sets."""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "bench",
        help="measure speed (fire, environment, planner, inference, DDS, system, network)",
        description="Run the benchmarks and report their figures.",
    )
    parser.add_argument(
        "--only",
        nargs="+",
        choices=sorted(SUITES),
        metavar="SUITE",
        help=f"run only these suites ({', '.join(SUITES)})",
    )
    parser.add_argument("--quick", action="store_true", help="shorter runs, noisier figures")
    parser.add_argument(
        "--smoke",
        action="store_true",
        help="run every suite once at its smallest size, to check that it works (figures "
        "meaningless; the tests run the whole bench so on both runtimes)",
    )
    add_device_argument(parser, "cpu", "the inference and training figures")
    parser.add_argument(
        "--map-size",
        type=map_size,
        metavar="R,C",
        help="the field world's map of the fire and env suites (default 1000,1000: "
        "fire.step_ms_map_1000, env.decisions_per_s_field, env.bytes_per_env_field)",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from wildfire_learning.device import resolve_device

    device = resolve_device(args.device)
    if args.only and "network" in args.only:
        # Asked for by name, it must run; in a full bench without root it is skipped (and says
        # why in its figures).
        from wildfire_testbed.hosts import namespaces_unavailable

        reason = namespaces_unavailable()
        if reason is not None:
            raise UserError(f"bench network: {reason}")
    results: dict[str, Any] = {
        "machine": {
            "cpus": len(__import__("os").sched_getaffinity(0)),
            "python": platform.python_version(),
            "torch": torch.__version__,
            "torch_threads": torch.get_num_threads(),
            "device": str(device),
        }
    }
    for name in args.only or list(SUITES):
        module_name, function_name, what = SUITES[name]
        try:
            function = getattr(importlib.import_module(module_name), function_name)
        except (ModuleNotFoundError, AttributeError):
            results[name] = {"skipped": f"{module_name}.{function_name} is not available"}
            continue
        if not args.json:
            print(f"[{name}] {what} ...", flush=True)
        tic = time.perf_counter()
        size = "smoke" if args.smoke else "quick" if args.quick else None
        kwargs: dict[str, Any] = dict(SIZES.get(size or "", {}).get(name, {}))
        if name in QUICK_CAPABLE:
            kwargs |= {"quick": args.quick, "smoke": args.smoke}
        if name in DEVICE_CAPABLE:
            kwargs["device"] = str(device)
        if name in MAP_CAPABLE and args.map_size is not None:
            kwargs["field_map"] = args.map_size
        figures = function(**kwargs)
        figures["bench_seconds"] = time.perf_counter() - tic
        results[name] = figures
        if not args.json:
            for key, value in figures.items():
                shown = f"{value:.4g}" if isinstance(value, float) else value
                print(f"  {key}: {shown}")
    results["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    if args.json:
        print_json(results)
    return 0
