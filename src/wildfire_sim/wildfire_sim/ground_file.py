"""A run's ground as one file the nodes read: the fuel and ignition rasters, already resolved.

``wildfire run --fuel-map F [--fuel-classes T] [--ignition-map I]`` reads the user's rasters
once, in the command's process (rasterio, class tables, resampling to 10 m, the crop to
``--map-size``), and writes what came out, per cell of the map, to ``ground.npz`` in the run's
log folder: the fuel ranges (int8), the spread multipliers (float32, when the table gives
any) and the cells burning at the start (bool), with the raster's name and SHA-256 for the
summaries. The fire simulator gets the file's path and the SHA-256 of its bytes as
parameters (``ground_file``, ``ground_sha256``; :mod:`wildfire_sim.ground_parameters`), reads
it with numpy alone and sends its bytes once, latched, on ``/wildfire/ground``. Every other
node gets the digest only, waits for the ground with that digest before it builds its
protocol (:mod:`wildfire_sim.ground_wire`), and refuses to start, in one line, if none comes.
So every node flies the very arrays that ``wildfire eval`` flies, on any host, and none reads
a file but the fire simulator.

Why the nodes wait: the aggregator and the agents' radio replicas build their protocol and
initial belief from the ground (the ignition on the raster's fuel) before they join the
lockstep barrier. The fire simulator sends the ground before it waits for anyone, so the
wait is the time of discovery.
"""

from __future__ import annotations

import hashlib
import io
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from wildfire_msgs_py.errors import ParameterError
from wildfire_msgs_py.map_geometry import MapGeometry
from wildfire_sim.fuel_map import FuelMap
from wildfire_sim.landscape import Landscape

FILE_NAME = "ground.npz"
"""The ground file's name in a run's log folder."""


def write_ground(ground: Landscape, path: Path) -> str:
    """Write the rasters of ``ground`` to ``path`` (an ``.npz``); return its bytes' SHA-256."""
    arrays: dict[str, Any] = {}  # (numpy's stub types savez's keywords as its options)
    fuel = ground.fuel
    if fuel is not None:
        arrays |= {
            "fuel_low": fuel.low,
            "fuel_high": fuel.high,
            "fuel_source": np.array(fuel.source),
            "fuel_sha256": np.array(fuel.sha256),
        }
        if fuel.spread is not None:
            arrays["fuel_spread"] = fuel.spread
    if ground.ignition_map is not None:
        arrays["ignition"] = ground.ignition_map
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    data = buffer.getvalue()
    path.write_bytes(data)
    return hashlib.sha256(data).hexdigest()


@lru_cache(maxsize=4)
def ground_bytes(path: str, sha256: str) -> bytes:
    """The bytes of the ground file at ``path``, checked against the run's ``sha256`` (the
    fire simulator's ``ground_file`` and ``ground_sha256``: what it reads and publishes;
    cached). Raises :class:`ParameterError` in one line."""
    what = f"parameter ground_file {path!r}"
    try:
        data = Path(path).read_bytes()
    except OSError as error:
        raise ParameterError(f"{what}: cannot be read ({error.strerror})") from None
    digest = hashlib.sha256(data).hexdigest()
    if sha256 and digest != sha256:
        raise ParameterError(
            f"{what}: SHA-256 {digest[:12]}..., expected {sha256[:12]}... (ground_sha256): "
            "not the file this run was launched with"
        )
    return data


@lru_cache(maxsize=4)
def read_ground(path: str, sha256: str, geometry: MapGeometry, ignitions: int) -> Landscape:
    """The landscape of the ground file at ``path`` (:func:`ground_bytes`), checked against
    ``geometry``."""
    return _landscape(ground_bytes(path, sha256), geometry, ignitions, f"ground_file {path!r}")


_RECEIVED: dict[str, bytes] = {}
"""Ground files this process received on ``/wildfire/ground``, by SHA-256 (composed agents
wait for it once)."""


def accept_ground(data: bytes, sha256: str) -> bool:
    """Keep a ground file received from the wire if its digest is ``sha256``."""
    if hashlib.sha256(data).hexdigest() != sha256:
        return False
    _RECEIVED[sha256] = data
    return True


def has_received(sha256: str) -> bool:
    return sha256 in _RECEIVED


@lru_cache(maxsize=4)
def received_ground(sha256: str, geometry: MapGeometry, ignitions: int) -> Landscape:
    """The landscape of the ground received with digest ``sha256`` (a node's ``ground_sha256``
    without ``ground_file``: the fire simulator's copy, from ``/wildfire/ground``)."""
    data = _RECEIVED.get(sha256)
    if data is None:
        raise ParameterError(
            f"parameter ground_sha256 {sha256[:12]}...: no such ground received on "
            "/wildfire/ground (the fire simulator publishes it from its ground_file)"
        )
    return _landscape(data, geometry, ignitions, "/wildfire/ground")


def _landscape(data: bytes, geometry: MapGeometry, ignitions: int, what: str) -> Landscape:
    """The landscape a ground file's bytes hold, checked (``what`` names them in errors)."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            arrays = {name: archive[name] for name in archive.files}
    except (OSError, ValueError) as error:
        raise ParameterError(f"{what}: not a ground file ({error})") from None
    expected: dict[str, type[np.generic]] = {
        "fuel_low": np.int8,
        "fuel_high": np.int8,
        "fuel_spread": np.float32,
        "ignition": np.bool_,
    }
    for name, dtype in expected.items():
        array = arrays.get(name)
        if array is not None and (array.dtype != dtype or array.shape != geometry.shape):
            raise ParameterError(
                f"{what}: {name} is {array.dtype} {array.shape}, expected {np.dtype(dtype)} "
                f"{geometry.shape} (map_rows, map_cols)"
            )
    fuel = None
    if "fuel_low" in arrays and "fuel_high" in arrays:
        fuel = FuelMap(
            arrays["fuel_low"],
            arrays["fuel_high"],
            arrays.get("fuel_spread"),
            str(arrays.get("fuel_source", what)),
            str(arrays.get("fuel_sha256", hashlib.sha256(data).hexdigest())),
        )
    ignition = arrays.get("ignition")
    if fuel is None and ignition is None:
        raise ParameterError(f"{what}: holds neither fuel (fuel_low, fuel_high) nor ignition")
    if ignition is not None and ignitions:
        raise ParameterError(f"{what}: an ignition map and ignitions={ignitions}: give one")
    return Landscape(geometry, fuel, ignition, ignitions)


__all__ = [
    "FILE_NAME",
    "accept_ground",
    "ground_bytes",
    "has_received",
    "read_ground",
    "received_ground",
    "write_ground",
]
