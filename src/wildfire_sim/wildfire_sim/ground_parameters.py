"""The ground parameters every node of a run shares: the map and how its fire starts.

The fire simulator, the belief aggregator and every agent declare :data:`GROUND_PARAMETERS`
(what ``ros2 param describe`` shows) beside their own, and :func:`ground_of` turns the values
into the :class:`~wildfire_sim.landscape.Landscape` the environment flies. So every node
sizes its maps and checks its inputs against the same geometry, and starts from the same
ignition (:func:`wildfire_sim.ignition.ignite`).

Fuel and ignition rasters (``--fuel-map``, ``--ignition-map``) do not fit in parameters:
the fire simulator's ``ground_file`` names the resolved rasters that ``wildfire run`` writes
(:mod:`wildfire_sim.ground_file`), and ``ground_sha256`` the digest every node checks them
against; the other nodes receive them on ``/wildfire/ground``. No node but the fire
simulator reads a file.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from wildfire_ros.node_support import ParamSpec
from wildfire_sim.defaults import EPISODE_DEFAULTS
from wildfire_sim.grid import MAX_SIDE, MIN_SIDE, PAPER_MAP, MapGeometry
from wildfire_sim.ground_file import read_ground, received_ground
from wildfire_sim.landscape import MAX_IGNITIONS, PAPER_LANDSCAPE, Landscape

GROUND_PARAMETERS = (
    ParamSpec("map_rows", PAPER_MAP.rows, "map cells of 10 m, south to north", MIN_SIDE, MAX_SIDE),
    ParamSpec("map_cols", PAPER_MAP.cols, "map cells of 10 m, west to east", MIN_SIDE, MAX_SIDE),
    ParamSpec(
        "ignitions",
        0,
        "seeded 5 x 5 ignitions on cells with fuel (0: the shape at the map's centre)",
        0,
        MAX_IGNITIONS,
    ),
    ParamSpec(
        "border_cells",
        EPISODE_DEFAULTS.border_cells,
        "the episode ends when fire is this close to the edge (seeded ignitions keep clear)",
        0,
        49,
    ),
    ParamSpec(
        "ground_file",
        "",
        "fire simulator: fuel and ignition rasters resolved by wildfire run (ground.npz in its "
        "log folder), sent on /wildfire/ground; '': none",
    ),
    ParamSpec(
        "ground_sha256",
        "",
        "SHA-256 of the run's ground file; without ground_file, wait for it on "
        "/wildfire/ground ('': no rasters, or the fire simulator's file unchecked)",
    ),
)


def ground_of(p: Mapping[str, Any]) -> Landscape:
    """The landscape of the ground parameter values ``p`` (of :data:`GROUND_PARAMETERS`)."""
    geometry = MapGeometry(p["map_rows"], p["map_cols"])
    if p["ground_file"]:
        return read_ground(p["ground_file"], p["ground_sha256"], geometry, p["ignitions"])
    if p["ground_sha256"]:
        return received_ground(p["ground_sha256"], geometry, p["ignitions"])
    if geometry.is_paper and not p["ignitions"]:
        return PAPER_LANDSCAPE
    return Landscape(geometry, ignitions=p["ignitions"])


def ground_values(
    ground: Landscape, border_cells: int, file: tuple[Path, str] | None = None
) -> dict[str, Any]:
    """The parameter values of ``ground`` (what the launcher passes every node); ``file``:
    the ground file holding its rasters and that file's SHA-256 (only the fire simulator
    keeps ``ground_file``, see :func:`wired_ground`)."""
    values: dict[str, Any] = {
        "map_rows": ground.geometry.rows,
        "map_cols": ground.geometry.cols,
        "ignitions": ground.ignitions,
        "border_cells": border_cells,
    }
    if file is not None:
        values |= {"ground_file": str(file[0]), "ground_sha256": file[1]}
    elif ground.has_rasters:
        raise ValueError("a ground with rasters travels in a ground file (write_ground)")
    return values


def wired_ground(values: dict[str, Any]) -> dict[str, Any]:
    """``values`` of a node other than the fire simulator: the digest without the file, so
    that it waits for the ground on ``/wildfire/ground``."""
    return {key: value for key, value in values.items() if key != "ground_file"}


__all__ = ["GROUND_PARAMETERS", "ground_of", "ground_values", "wired_ground"]
