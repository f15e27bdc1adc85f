"""Shared pieces of the command-line tool: parser class, argument types, JSON output."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from wildfire_belief.radio import CommError, CommModel
from wildfire_belief.sensors import SENSORS
from wildfire_msgs_py.map_geometry import (
    MAX_SIDE,
    MIN_SIDE,
    PAPER_MAP,
    MapGeometry,
    MapGeometryError,
)
from wildfire_sim.defaults import EPISODE_DEFAULTS
from wildfire_sim.landscape import Landscape


class UserError(Exception):
    """A mistake in what the user asked for; reported as one line, exit status 2."""


def _project_user_errors() -> tuple[type[BaseException], ...]:
    """Error classes of the project packages that describe bad user input."""
    errors: list[type[BaseException]] = [UserError]
    for module_name, class_name in (
        ("wildfire_msgs_py.errors", "WildfireRosError"),
        ("wildfire_sim.errors", "FireConfigError"),
        ("wildfire_agent.errors", "AgentConfigError"),
        ("wildfire_world.errors", "WorldError"),
        ("wildfire_learning.errors", "LearningError"),
        ("wildfire_belief.radio", "CommError"),
    ):
        try:
            module = __import__(module_name, fromlist=[class_name])
        except ModuleNotFoundError:
            continue
        errors.append(getattr(module, class_name))
    return tuple(errors)


USER_ERRORS = _project_user_errors()


class ArgumentParser(argparse.ArgumentParser):
    """argparse with one-line errors: ``wildfire eval: error: --wind: expected WX,WY``."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def non_negative_int(text: str) -> int:
    """argparse type: an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {value}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    value = non_negative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text}")
    return value


def wind_vector(text: str) -> tuple[float, float]:
    """argparse type: ``WX,WY`` with each component in [-1, 1] (dimensionless wind)."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        wx, wy = (float(part) for part in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected WX,WY (two numbers in [-1, 1], e.g. 0.5,0), got {text!r}"
        ) from None
    if not (abs(wx) <= 1.0 and abs(wy) <= 1.0):
        raise argparse.ArgumentTypeError(f"expected components in [-1, 1], got {text!r}")
    return wx, wy


def unit_interval(text: str) -> float:
    """argparse type: a number in [0, 1] (a probability, a wind bound)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1], got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1], got {text}")
    return value


def comm_model(text: str) -> CommModel:
    """argparse type: a radio model, ``ideal``, ``none`` or ``range=R[,loss=P][,delay=D]``."""
    try:
        return CommModel.parse(text)
    except CommError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_comm_argument(parser: argparse.ArgumentParser | argparse._ActionsContainer) -> None:
    """``--comm MODEL``: the radio links between the aircraft (default: ideal)."""
    parser.add_argument(
        "--comm",
        type=comm_model,
        default=CommModel(),
        metavar="MODEL",
        help="radio links: ideal (one shared belief, the default), none, or "
        "range=R[,loss=P][,delay=D] (metres, loss probability per message, decisions): each "
        "aircraft then decides on its own belief replica and what it heard of its peers",
    )


def map_size(text: str) -> MapGeometry:
    """argparse type: ``ROWS,COLS`` cells of 10 m, each in [50, 2000]."""
    try:
        return MapGeometry.parse(text)
    except MapGeometryError as error:
        raise argparse.ArgumentTypeError(str(error).removeprefix("map size: ")) from None


def add_map_arguments(parser: argparse.ArgumentParser | argparse._ActionsContainer) -> None:
    """The map's and the fire start's options (``map_settings`` and ``landscape_of`` read
    them)."""
    parser.add_argument(
        "--map-size",
        type=map_size,
        default=None,
        metavar="R,C",
        help=f"rows and columns of 10 m cells, each in [{MIN_SIDE}, {MAX_SIDE}] (default "
        f"{PAPER_MAP.text}: the paper's 1 km square, or a fuel map's extent); named shapes "
        "sit at the map's centre",
    )
    parser.add_argument(
        "--fuel-map",
        type=Path,
        metavar="FILE",
        help="fuel from a GeoTIFF (projected CRS in metres, resampled to 10 m cells) or a .npy "
        "(10 m cells, row 0 south): band 1 is fuel in fire steps (0..127), or class codes "
        "with --fuel-classes; nodata and 0 burn nothing",
    )
    parser.add_argument(
        "--fuel-classes",
        metavar="TABLE",
        help="the fuel map holds land-cover classes: corine, fbfm13 or a YAML table "
        "(class -> fuel range, spread multiplier)",
    )
    starts = parser.add_mutually_exclusive_group()
    starts.add_argument(
        "--ignition-map",
        type=Path,
        metavar="FILE",
        help="cells burning at the start: nonzero cells of a GeoTIFF or .npy on the map",
    )
    starts.add_argument(
        "--ignitions",
        type=non_negative_int,
        default=0,
        metavar="K",
        help="light K seeded 5 x 5 blocks on cells with fuel instead of the shape",
    )
    parser.add_argument(
        "--preburn-area",
        type=positive_float,
        default=None,
        metavar="M2",
        help="pre-burn until the fire has touched M2 square metres (default: 30 fire steps)",
    )


def landscape_of(args: argparse.Namespace) -> Landscape | None:
    """The landscape of ``add_map_arguments``; None for the paper's fuel and shapes."""
    from wildfire_sim.landscape import read_landscape

    return read_landscape(
        args.map_size, args.fuel_map, args.fuel_classes, args.ignition_map, args.ignitions
    )


def map_settings(args: argparse.Namespace) -> dict[str, Any]:
    """``EnvConfig`` fields of ``add_map_arguments``."""
    landscape = landscape_of(args)
    settings: dict[str, Any] = {
        "geometry": landscape.geometry if landscape else args.map_size or PAPER_MAP,
        "landscape": landscape,
    }
    if args.preburn_area is not None:
        settings["preburn_area_m2"] = args.preburn_area
    return settings


CAMERA_PIXEL_ERROR = 0.1
"""The camera's pixel error unless given (the disc's is 0: the paper's perfect sensor)."""


def pixel_error(text: str) -> float:
    """argparse type: a flip probability in [0, 0.5) (at 0.5 a report says nothing)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 0.5), got {text!r}") from None
    if not 0.0 <= value < 0.5:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 0.5), got {text}")
    return value


def add_sensor_arguments(parser: argparse.ArgumentParser) -> None:
    """``--sensor disc|camera`` and ``--pixel-error P`` (``sensor_settings`` reads them)."""
    parser.add_argument(
        "--sensor",
        choices=SENSORS,
        default="disc",
        help="disc (the paper's: every cell within 100 m, perfectly; the default) or camera "
        "(four body-fixed cameras; the team then keeps a probability of burning per cell)",
    )
    parser.add_argument(
        "--pixel-error",
        type=pixel_error,
        default=None,
        metavar="P",
        help=f"probability that a report flips (default {CAMERA_PIXEL_ERROR:g} for camera, "
        "0 for disc)",
    )
    parser.add_argument(
        "--wind-filter",
        action="store_true",
        help="under noisy sensing, estimate the wind with a particle filter of 40 fire "
        "models for the belief's process term (~2 ms more per decision per team)",
    )


def sensor_settings(args: argparse.Namespace) -> dict[str, Any]:
    """``EnvConfig`` fields of ``add_sensor_arguments``."""
    error = args.pixel_error
    if error is None:
        error = CAMERA_PIXEL_ERROR if args.sensor == "camera" else 0.0
    return {"sensor": args.sensor, "pixel_error": error, "wind_filter": args.wind_filter}


def add_episode_arguments(
    parser: argparse.ArgumentParser, default_seed: int, seed_help: str
) -> None:
    """The scenario arguments ``eval`` and ``run`` share: policy, team, fire, wind, seed,
    duration (``scenario_settings`` turns them into ``EnvConfig`` fields)."""
    parser.add_argument(
        "--policy",
        default="rh",
        help="rh (our receding horizon), rh-paper (the paper's, uncoordinated), rh-belief (rh on "
        "the believed map), random, obs, belief, belief-radio, belief-camera, "
        "belief-camera-radio, obs-camera (shipped models; belief-radio trained under limited "
        "radio links, belief-camera and obs-camera under camera sensing, belief-camera-radio "
        "under both) or a TorchScript .pt",
    )
    parser.add_argument("--aircraft", type=positive_int, default=2, metavar="N")
    parser.add_argument("--shape", default="circular", help="circular, t or arc")
    winds = parser.add_mutually_exclusive_group()
    winds.add_argument(
        "--wind",
        type=wind_vector,
        default=None,
        metavar="WX,WY",
        help="fixed wind; by default each seed draws it in [-W, W]^2 (see --max-wind)",
    )
    add_max_wind_argument(winds)
    parser.add_argument(
        "--seed", type=non_negative_int, default=default_seed, metavar="S", help=seed_help
    )
    add_duration_argument(parser)
    add_comm_argument(parser)
    add_sensor_arguments(parser)
    add_map_arguments(parser)


def add_max_wind_argument(parser: argparse.ArgumentParser | argparse._ActionsContainer) -> None:
    """``--max-wind W`` (default None: the environment's bound)."""
    parser.add_argument(
        "--max-wind",
        type=unit_interval,
        default=None,
        metavar="W",
        help="bound W of each random wind component (default "
        f"{EPISODE_DEFAULTS.max_wind:g}, the training range); a "
        "seed keeps its draw, so a smaller W flies the same episodes under weaker wind",
    )


def add_duration_argument(parser: argparse.ArgumentParser) -> None:
    """``--duration SEC``, the flight limit of an episode."""
    parser.add_argument(
        "--duration",
        type=positive_float,
        default=EPISODE_DEFAULTS.duration_s,
        metavar="SEC",
        help="longest flight in seconds (the fire reaching the border ends it too)",
    )


def ray_address(text: str) -> str:
    """argparse type: ``HOST:PORT`` (optionally ``ray://HOST:PORT``) or ``auto``."""
    if text == "auto":
        return text
    host, sep, port = text.removeprefix("ray://").rpartition(":")
    if not (sep and host and port.isdigit() and 0 < int(port) < 65536):
        raise argparse.ArgumentTypeError(f"expected HOST:PORT or auto, got {text!r}")
    return text


def add_parallel_arguments(parser: argparse.ArgumentParser) -> None:
    """``--workers N`` / ``--ray ADDRESS`` of ``eval`` and ``report``: where episodes fly
    (``wildfire_learning.parallel``; the results equal a serial run's)."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=positive_int,
        default=1,
        metavar="N",
        help="spread the episodes over N local processes (default: 1, this process); the "
        "results equal a serial run's bit for bit",
    )
    where.add_argument(
        "--ray",
        type=ray_address,
        default=None,
        metavar="ADDRESS",
        help="run the evaluation tasks on the Ray cluster at HOST:PORT (auto: the one started "
        "by `ray start` on this machine); same results",
    )


def add_device_argument(parser: argparse.ArgumentParser, default: str, what: str) -> None:
    """``--device cpu|cuda|cuda:N|auto`` (checked against the machine when used)."""
    parser.add_argument(
        "--device",
        default=default,
        metavar="DEVICE",
        help=f"cpu, cuda, cuda:N or auto (CUDA if present) for {what} (default: {default})",
    )


def scenario_settings(args: argparse.Namespace) -> dict[str, Any]:
    """``EnvConfig`` fields set by the arguments of ``add_episode_arguments`` (but the shape);
    an unset ``--max-wind`` keeps the environment's default."""
    settings: dict[str, Any] = {
        "n_aircraft": args.aircraft,
        "wind": args.wind,
        "max_duration_s": args.duration,
        "comm": args.comm,
        **sensor_settings(args),
        **map_settings(args),
    }
    if args.max_wind is not None:
        settings["max_wind"] = args.max_wind
    return settings


def print_json(payload: dict[str, Any]) -> None:
    """Print a JSON summary on stdout (numpy scalars and arrays converted)."""

    def convert(value: Any) -> Any:
        if isinstance(value, np.ndarray):
            return value.tolist()
        if isinstance(value, np.generic):
            return value.item()
        raise TypeError(f"not JSON serialisable: {type(value).__name__}")

    json.dump(payload, sys.stdout, default=convert, indent=2)
    sys.stdout.write("\n")
