"""``wildfire sensor``: the map cells each of the four cameras sees from one pose."""

from __future__ import annotations

import argparse
import math

import numpy as np

from wildfire_agent.camera import NUM_CAMERAS, ROLL_DEG, camera_cells
from wildfire_agent.dynamics import BANK_STEP_RAD, MAX_BANK_STEPS
from wildfire_cli.common import print_json

BANK_STEP_DEG = round(math.degrees(BANK_STEP_RAD))
MAX_BANK_DEG = MAX_BANK_STEPS * BANK_STEP_DEG
# One colour per camera, left wing (camera 0) to right wing (camera 3).
CAMERA_COLOURS = ("#1f77b4", "#2ca02c", "#ff7f0e", "#d62728")


def finite_float(text: str) -> float:
    """argparse type: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text}")
    return value


def bank_steps(text: str) -> int:
    """argparse type: a bank in degrees, a whole multiple of 5 in [-50, 50], as 5-degree
    steps (the aircraft only ever holds such banks)."""
    value = finite_float(text)
    steps = round(value / BANK_STEP_DEG)
    if steps * BANK_STEP_DEG != value or abs(steps) > MAX_BANK_STEPS:
        raise argparse.ArgumentTypeError(
            f"expected a multiple of {BANK_STEP_DEG} in [-{MAX_BANK_DEG}, {MAX_BANK_DEG}] "
            f"degrees, got {text}"
        )
    return steps


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "sensor",
        help="show the cells the four cameras see from one pose",
        description="List the map cells each of the four cameras sees from an aircraft at "
        "(X, Y) metres, 200 m up, with the given heading and bank (see "
        "wildfire_agent/camera.py). Cameras 0..3 are rolled +40, +13, -13, -40 degrees "
        "(left wing to right wing).",
    )
    parser.add_argument("--x", type=finite_float, required=True, metavar="X", help="east, m")
    parser.add_argument("--y", type=finite_float, required=True, metavar="Y", help="north, m")
    parser.add_argument(
        "--heading",
        type=finite_float,
        required=True,
        metavar="DEG",
        help="degrees counter-clockwise from east",
    )
    parser.add_argument(
        "--bank",
        type=bank_steps,
        required=True,
        metavar="DEG",
        help=f"degrees, a multiple of {BANK_STEP_DEG} in [-{MAX_BANK_DEG}, {MAX_BANK_DEG}]; "
        "positive lowers the left wing (a left turn)",
    )
    parser.add_argument("--png", metavar="FILE", help="draw the footprints on the map")
    parser.add_argument(
        "--json",
        action="store_true",
        help='print {"cameras": [[[row, col], ...] x 4]}, each camera\'s cells row-major',
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    heading_rad = float(np.deg2rad(args.heading))
    cells = camera_cells(args.x, args.y, heading_rad, args.bank)
    if args.png:
        plot_footprints(cells, args.x, args.y, heading_rad, args.png, _title(args))
    if args.json:
        print_json({"cameras": [camera.tolist() for camera in cells]})
    else:
        for camera, seen in enumerate(cells):
            print(f"camera {camera} (roll {ROLL_DEG[camera]:+g} deg): {len(seen)} cells")
        if args.png:
            print(f"wrote {args.png}")
    return 0


def _title(args: argparse.Namespace) -> str:
    return (
        f"cameras from ({args.x:g}, {args.y:g}) m, heading {args.heading:g} deg, "
        f"bank {args.bank * BANK_STEP_DEG:+d} deg"
    )


def plot_footprints(
    cells: list[np.ndarray], x_m: float, y_m: float, heading_rad: float, path: str, title: str
) -> None:
    """Draw each camera's cells on the map, with the aircraft and its heading."""
    import matplotlib

    matplotlib.use("Agg")  # files only: never open a window
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Patch

    from wildfire_sim.grid import PAPER_MAP

    # The footprints of one pose are drawn on the paper's 1 km map around it.
    map_size_m = PAPER_MAP.width_m

    fig, ax = plt.subplots(figsize=(6, 6))
    # Translucent layers, so a cell two cameras share shows both colours mixed.
    for camera in range(NUM_CAMERAS):
        layer = np.zeros((*PAPER_MAP.shape, 4))
        rows, cols = cells[camera].T
        layer[rows, cols] = to_rgba(CAMERA_COLOURS[camera], alpha=0.55)
        ax.imshow(
            layer,
            origin="lower",
            extent=(0.0, map_size_m, 0.0, map_size_m),
            interpolation="nearest",
        )
    ax.plot(x_m, y_m, "ko", ms=5)
    arrow_m = 0.08 * map_size_m
    ax.annotate(
        "",
        xy=(x_m + arrow_m * math.cos(heading_rad), y_m + arrow_m * math.sin(heading_rad)),
        xytext=(x_m, y_m),
        arrowprops={"arrowstyle": "->", "color": "k", "lw": 1.5},
    )
    ax.legend(
        handles=[
            Patch(
                color=CAMERA_COLOURS[camera], label=f"camera {camera} ({ROLL_DEG[camera]:+g} deg)"
            )
            for camera in range(NUM_CAMERAS)
        ],
        fontsize=7,
        loc="upper right",
    )
    ax.set_title(title, fontsize=9)
    ax.set_xlim(0, map_size_m)
    ax.set_ylim(0, map_size_m)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)", fontsize=8)
    ax.set_ylabel("north (m)", fontsize=8)
    ax.tick_params(labelsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


__all__ = [
    "BANK_STEP_DEG",
    "CAMERA_COLOURS",
    "MAX_BANK_DEG",
    "add_parser",
    "bank_steps",
    "finite_float",
    "plot_footprints",
    "run",
]
