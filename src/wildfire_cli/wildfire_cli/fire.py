"""``wildfire fire``: simulate the fire model alone, from ignition (no pre-burn unless
``--preburn-area``), on any map and landscape."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from wildfire_cli.common import (
    add_map_arguments,
    landscape_of,
    non_negative_int,
    positive_int,
    print_json,
    wind_vector,
)
from wildfire_cli.progress import progress_bar
from wildfire_sim.episode import EPISODE_DEFAULTS, preburn
from wildfire_sim.fire import BatchedFire
from wildfire_sim.grid import CELL_SIZE_M, PAPER_MAP
from wildfire_sim.landscape import Landscape
from wildfire_sim.shapes import Shape


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "fire",
        help="simulate the wildfire model alone",
        description="Simulate the fire from ignition (no pre-burn) for K fire steps (2.5 s "
        "each) over seeds 0..N-1 and report the mean burning and affected cell counts.",
    )
    parser.add_argument("--shape", default="circular", help="circular, t or arc")
    parser.add_argument(
        "--wind",
        type=wind_vector,
        default=(0.0, 0.0),
        metavar="WX,WY",
        help="dimensionless wind, each in [-1, 1]; WX > 0 blows east",
    )
    parser.add_argument("--steps", type=non_negative_int, default=60, metavar="K")
    parser.add_argument("--seeds", type=positive_int, default=10, metavar="N")
    add_map_arguments(parser)
    parser.add_argument("--png", metavar="FILE", help="draw the fire of seed 0 over time")
    parser.add_argument(
        "--out",
        type=Path,
        metavar="FILE.npz",
        help="save the final burning (N, R, C) bool and fuel (N, R, C) int8 of every seed, in "
        "the map's [row, col] layout (row 0 south, 10 m cells)",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    shape = Shape.parse(args.shape)
    landscape = landscape_of(args) or Landscape(args.map_size or PAPER_MAP)
    seeds = np.arange(args.seeds)
    starts = [landscape.start(shape, int(seed), EPISODE_DEFAULTS.border_cells) for seed in seeds]
    fire = BatchedFire(args.seeds, geometry=landscape.geometry, fuel_map=landscape.fuel)
    fire.reset(
        seeds,
        seeds,
        np.stack([start.ignition for start in starts]),
        np.stack([start.fuel for start in starts]),
        np.asarray(args.wind),
    )
    if args.preburn_area is not None:
        preburn(fire, np.ones(args.seeds, dtype=bool), 0, args.preburn_area)
    mean_burning: list[float] = []
    mean_affected: list[float] = []
    snapshot_steps = set(np.linspace(0, args.steps, 4).round().astype(int).tolist())
    frames = []
    with progress_bar("fire steps", args.steps, enabled=not args.json) as update:
        for step in range(args.steps + 1):
            if step in snapshot_steps:
                frames.append(
                    (step, fire.burning[0].copy(), fire.affected()[0].copy(), fire.fuel[0].copy())
                )
            if step == args.steps:
                break
            fire.step()
            mean_burning.append(float(fire.burning.sum(axis=(1, 2)).mean()))
            mean_affected.append(float(fire.affected().sum(axis=(1, 2)).mean()))
            update(step + 1)
    affected = fire.affected()
    centroids = []
    for env in range(args.seeds):
        rows, cols = np.nonzero(affected[env])
        if rows.size:
            centroids.append(((cols.mean() + 0.5) * CELL_SIZE_M, (rows.mean() + 0.5) * CELL_SIZE_M))
    centroid = np.mean(centroids, axis=0).tolist() if centroids else [float("nan")] * 2
    if args.png:
        from wildfire_learning.plots import plot_fire_propagation

        plot_fire_propagation(
            frames, args.png, f"{args.shape} fire, wind {args.wind[0]:+.2f},{args.wind[1]:+.2f}"
        )
    if args.out is not None:
        np.savez_compressed(
            args.out, burning=fire.burning, fuel=fire.fuel, seeds=seeds, cell_size_m=CELL_SIZE_M
        )
    summary = {
        **landscape.summary(),
        "shape": shape.value,
        "wind": list(args.wind),
        "steps": args.steps,
        "seeds": args.seeds,
        "mean_burning": mean_burning,
        "mean_affected": mean_affected,
        "mean_centroid_m": centroid,
    }
    if args.json:
        print_json(summary)
    else:
        last_burning = mean_burning[-1] if mean_burning else 0.0
        last_affected = mean_affected[-1] if mean_affected else 0.0
        print(
            f"{args.shape} fire, {args.seeds} seeds, {args.steps} steps "
            f"({args.steps * 2.5:.0f} s): {last_burning:.0f} cells burning, "
            f"{last_affected:.0f} affected, centroid ({centroid[0]:.0f}, {centroid[1]:.0f}) m"
        )
        for path in (args.png, args.out):
            if path:
                print(f"wrote {path}")
    return 0
