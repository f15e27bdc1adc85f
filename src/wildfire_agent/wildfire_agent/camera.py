"""Four downward cameras under the wing: which map cells each one sees, and its noisy reports.

Frames
------
World: x east, y north, z up, ground at z = 0; the aircraft flies at ``ALTITUDE_M`` (200 m).
Heading psi is counter-clockwise from east; a positive bank phi lowers the left wing (and
turns left, as in ``wildfire_agent.dynamics``). The body axes of the banked aircraft are

* forward ``f = (cos psi, sin psi, 0)``,
* left ``l = cos phi * s - sin phi * z``,
* up ``u = sin phi * s + cos phi * z``,

with ``s = (-sin psi, cos psi, 0)`` the level left direction and ``z = (0, 0, 1)``.

Cameras
-------
Camera i starts looking straight down, is pitched ``PITCH_DEG`` (30 degrees) forward, then
rolled ``ROLL_DEG[i]`` (+40, +13, -13, -40 degrees; positive toward the left wing) about
the body forward axis. In (f, l, u) components its optical axis, image x-axis and image
y-axis are::

    a_i = (sin theta,  cos theta sin phi_i, -cos theta cos phi_i)
    h_i = (0,          cos phi_i,            sin phi_i)
    v_i = (cos theta, -sin theta sin phi_i,  sin theta cos phi_i)

(an orthonormal triple). Camera 0 looks furthest left, camera 3 furthest right. Each is a
pinhole of focal length 50 mm behind a 24 mm (x, 20 pixels) by 36 mm (y, 30 pixels)
sensor: half fields of view of atan(12 / 50) = 13.5 degrees across and atan(18 / 50) =
19.8 degrees along. The rolls are 27 and 26 degrees apart, about one across-track field of
view (27 degrees), so at bank 0 the four footprints lie side by side in one band ahead of
the aircraft, about 35 m to 270 m ahead and 275 m to either side (~1 010 cells; 326, 256,
256 and 326 per camera, the outer two cut by the 300 m range). The band is not an exact
tiling: the side edges of a pitched, rolled pyramid are not parallel to the track, so
neighbours overlap in wedges that widen ahead (41 to 51 cells per pair, ~14% of the band
seen twice; cameras two apart never share a cell), and the inner cameras' far edges reach
only ~240 m near the track, a notch in the band's far edge. A bank turns the whole rig
with the airframe: in a left turn the cameras look to the right, out of the turn; at
+/-50 degrees the outer camera on the raised wing looks at the horizon and sees nothing
within 300 m.

Footprint
---------
A map cell is seen by camera i when its centre P (on the ground) has, with
``r = P - (x, y, h)``: ``r . a_i > 0``, ``|50 (r . h_i) / (r . a_i)| <= 12`` and
``|50 (r . v_i) / (r . a_i)| <= 18`` (its image falls on the sensor), lies within
``RANGE_M`` (300 m) horizontally of the aircraft, and is inside the map. The rule is per
cell, not per pixel: one pixel spans 1.2 mm / 50 mm of the slant range, 5 m to 15 m on the
ground over these footprints, about one 10 m cell, so a cell stands for a pixel.

Cells within 300 m of the aircraft have their centres at most 30 cells from the
aircraft's cell (the aircraft may sit anywhere inside it), so every footprint fits in a
``CAMERA_WINDOW`` x ``CAMERA_WINDOW`` (61 x 61) window centred on that cell, the same
window layout as the visits of ``wildfire_belief.visits``. The footprints of a whole batch
of poses are then computed with broadcasting over a fixed shape, with no loop over cells.

Noise
-----
Each seen cell reports its true burning value, flipped with probability p
(``PIXEL_ERROR``, 0.1) independently per camera and decision. The uniforms come from the
aircraft's own generator, in a fixed order, so an aircraft's reports for a seed do not
depend on which or how many other aircraft share the batch (see :func:`noisy_reports`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from wildfire_agent.dynamics import BANK_STEP_RAD, MAX_BANK_STEPS
from wildfire_belief.sensors import CAMERA_WINDOW, CAMERA_WINDOW_HALF, NUM_CAMERAS
from wildfire_belief.visits import cell_offset_m, window_cells
from wildfire_belief.window_runs import WindowRuns, run_cells, runs_of
from wildfire_sim.grid import CELL_SIZE_M, PAPER_MAP, MapGeometry

ALTITUDE_M = 200.0
"""Flight altitude h above the ground."""
ROLL_DEG = (40.0, 13.0, -13.0, -40.0)
"""Roll of each camera about the body forward axis, positive toward the left wing."""
PITCH_DEG = 30.0
"""Forward pitch of every camera from straight down."""
FOCAL_LENGTH_MM = 50.0
SENSOR_X_MM = 24.0
"""Sensor extent along the image x-axis (across the track at bank 0)."""
SENSOR_Y_MM = 36.0
"""Sensor extent along the image y-axis (along the track at bank 0)."""
PIXELS_X = 20
PIXELS_Y = 30
RANGE_M = 300.0
"""Cells further than this horizontally from the aircraft are not seen."""
PIXEL_ERROR = 0.1
"""Probability that a seen cell reports the opposite of its true burning value."""
WINDOW_HALF = CAMERA_WINDOW_HALF
"""Cells from the aircraft's cell to the window edge: a centre 31 cells off is > 300 m away."""

_TAN_HALF_X = SENSOR_X_MM / 2.0 / FOCAL_LENGTH_MM
_TAN_HALF_Y = SENSOR_Y_MM / 2.0 / FOCAL_LENGTH_MM


def camera_axes() -> np.ndarray:
    """Body-frame axes of the cameras, (4, 3, 3): ``[camera, (a, h, v), (f, l, u)]``.

    ``a`` is the optical axis, ``h`` and ``v`` the image x- and y-axes.
    """
    theta = np.deg2rad(PITCH_DEG)
    phi = np.deg2rad(np.asarray(ROLL_DEG))
    zero = np.zeros_like(phi)
    a = [
        np.full_like(phi, np.sin(theta)),
        np.cos(theta) * np.sin(phi),
        -np.cos(theta) * np.cos(phi),
    ]
    h = [zero, np.cos(phi), np.sin(phi)]
    v = [
        np.full_like(phi, np.cos(theta)),
        -np.sin(theta) * np.sin(phi),
        np.sin(theta) * np.cos(phi),
    ]
    return np.stack([np.stack(a, axis=-1), np.stack(h, axis=-1), np.stack(v, axis=-1)], axis=1)


def _edge_normals() -> np.ndarray:
    """Inward normals of each camera's four side planes per bank step, (21, 4, 4, 3).

    Indexed ``[bank_steps + 10, camera, side, (f, s, z)]``: r is inside the field of view
    when r . n >= 0 for all four sides. ``|50 (r . h) / (r . a)| <= 12`` is the pair
    ``r . (t a - h) >= 0``, ``r . (t a + h) >= 0`` with t = 12 / 50 (likewise v, 18 / 50);
    these two also give ``r . a >= 0``, and ``r . a = 0`` would then force ``r . h = r . v
    = 0``, i.e. r = 0, impossible 200 m above the ground, so ``r . a > 0`` needs no test.
    Components are in the level frame (f, s, z): the bank only mixes l and u into s and z,
    so the 21 banks are done once, here; the heading then turns f and s about the vertical.
    """
    a, h, v = np.moveaxis(camera_axes(), 1, 0)  # each (4, 3) in (f, l, u)
    sides = np.stack(
        [_TAN_HALF_X * a - h, _TAN_HALF_X * a + h, _TAN_HALF_Y * a - v, _TAN_HALF_Y * a + v],
        axis=1,
    )  # (4, 4, 3)
    bank = np.arange(-MAX_BANK_STEPS, MAX_BANK_STEPS + 1) * BANK_STEP_RAD
    cos_b, sin_b = np.cos(bank)[:, None, None], np.sin(bank)[:, None, None]
    along_f, along_l, along_u = sides[..., 0], sides[..., 1], sides[..., 2]
    along_s = along_l * cos_b + along_u * sin_b
    along_z = -along_l * sin_b + along_u * cos_b
    return np.stack([np.broadcast_to(along_f, along_s.shape), along_s, along_z], axis=-1)


_EDGE_NORMALS = _edge_normals()


class CameraWindows(NamedTuple):
    """Camera footprints of a batch of aircraft (leading dims of the poses, e.g. (E, N))."""

    row0: np.ndarray
    """Row of the window's southern edge (may be outside the map), int64."""
    col0: np.ndarray
    """Column of the window's western edge (may be outside the map), int64."""
    runs: WindowRuns
    """(..., 4, 61) per camera and window row: the run of seen columns (inside the map)."""

    @property
    def seen(self) -> np.ndarray:
        """(..., 4, 61, 61) bool: cell seen by the camera (and inside the map)."""
        return self.runs.mask(CAMERA_WINDOW)


def camera_windows(
    x_m: np.ndarray,
    y_m: np.ndarray,
    heading_rad: np.ndarray,
    bank_steps: np.ndarray,
    geometry: MapGeometry = PAPER_MAP,
) -> CameraWindows:
    """The camera footprints of aircraft at the given poses (any matching shapes).

    ``bank_steps`` is the bank in 5-degree steps, integers in [-10, 10] (as
    ``AircraftState.bank_steps``).

    A footprint is the ground inside four planes through the aircraft, cut by the 300 m
    disc and the map: convex. So in each window row a camera sees one run of columns, whose
    ends follow from the four edge lines and the disc at that row's northing, found exactly
    (``camera_kernels.footprint_runs``: the same float comparisons as the per-cell rule).
    The work is per (camera, row), not per cell, and the reports then need no scan of
    61 x 61 masks. The same cells are found.
    """
    x_m, y_m = np.asarray(x_m, dtype=np.float64), np.asarray(y_m, dtype=np.float64)
    heading_rad = np.asarray(heading_rad, dtype=np.float64)
    bank_steps = np.asarray(bank_steps)
    if not np.issubdtype(bank_steps.dtype, np.integer):
        raise ValueError(f"bank_steps must be integers, got {bank_steps.dtype}")
    if np.any(np.abs(bank_steps) > MAX_BANK_STEPS):
        # A negative index would silently wrap to another bank's normals.
        raise ValueError(f"bank_steps must lie in [-{MAX_BANK_STEPS}, {MAX_BANK_STEPS}]")
    # The window layout of the visits' disc_window: rows and columns around the aircraft's cell.
    half, side = WINDOW_HALF, CAMERA_WINDOW
    row = np.floor(y_m / CELL_SIZE_M).astype(np.int64)
    col = np.floor(x_m / CELL_SIZE_M).astype(np.int64)
    rows = row[..., None] + np.arange(-half, half + 1)  # (..., 61)
    dy = cell_offset_m(rows, y_m[..., None])
    normals = _EDGE_NORMALS[bank_steps + MAX_BANK_STEPS]  # (..., 4, 4, 3)
    cos_h = np.cos(heading_rad)[..., None, None]
    sin_h = np.sin(heading_rad)[..., None, None]
    east = normals[..., 0] * cos_h - normals[..., 1] * sin_h  # (..., 4, 4)
    north = normals[..., 0] * sin_h + normals[..., 1] * cos_h
    # Per window row and camera, the four sides bound dx; the run's ends follow from these
    # bounds and the 300 m disc (one run too, around dx = 0), cut by the map's columns; a
    # row off the map or with no cell in range is empty. A compiled search per entry
    # (imported here: numba costs ~0.5 s of start-up).
    from wildfire_agent.camera_kernels import footprint_runs

    lead = east.shape[:-2]
    poses = int(np.prod(lead, dtype=np.int64))

    def flat(values: np.ndarray, *tail: int) -> np.ndarray:
        return np.ascontiguousarray(np.broadcast_to(values, (*lead, *tail))).reshape(poses, *tail)

    sides = (NUM_CAMERAS, 4)
    first, stop = footprint_runs(
        flat(east, *sides),
        flat(north, *sides),
        flat(normals[..., 2], *sides),
        flat(dy, side),
        flat(rows, side),
        flat(x_m),
        flat(col - half),
        geometry.rows,
        geometry.cols,
        CELL_SIZE_M,
        RANGE_M,
        ALTITUDE_M,
    )
    runs = WindowRuns(*(ends.reshape(*lead, NUM_CAMERAS, side) for ends in (first, stop)))
    return CameraWindows(row0=row - half, col0=col - half, runs=runs)


def camera_cells(
    x_m: float,
    y_m: float,
    heading_rad: float,
    bank_steps: int,
    geometry: MapGeometry = PAPER_MAP,
) -> list[np.ndarray]:
    """The cells each camera of one aircraft sees: 4 arrays (K, 2) of (row, col), int64,
    in row-major order (ascending flat cell index)."""
    windows = camera_windows(
        np.asarray(x_m),
        np.asarray(y_m),
        np.asarray(heading_rad),
        np.asarray(bank_steps),
        geometry,
    )
    cells = []
    for camera in range(NUM_CAMERAS):
        i, j = np.nonzero(windows.seen[camera])  # row-major, like the flat map index
        cells.append(np.stack([windows.row0 + i, windows.col0 + j], axis=-1).astype(np.int64))
    return cells


def window_values(grid: np.ndarray, windows: CameraWindows) -> np.ndarray:
    """Values of a (E, H, W) grid in each camera window, (E, N, 61, 61); 0 outside the map.

    ``windows`` has leading dims (E, N). This is the truth :func:`noisy_reports` flips.
    """
    return window_cells(grid, windows.row0, windows.col0, CAMERA_WINDOW)


def noisy_reports(
    truth: np.ndarray,
    seen: np.ndarray,
    rngs: Sequence[np.random.Generator],
    p: float = PIXEL_ERROR,
) -> np.ndarray:
    """What the cameras report: each seen cell's truth, flipped with probability ``p``.

    Parameters
    ----------
    truth : (..., 61, 61) array
        Burning values in each aircraft's window (nonzero is burning), e.g. from
        :func:`window_values`.
    seen : (..., 4, 61, 61) bool
        The footprints, ``CameraWindows.seen`` (one run of seen cells per row).
    rngs : sequence of numpy.random.Generator
        One generator per aircraft, in C order of the leading dims (for (E, N): aircraft
        ``n`` of environment ``e`` is ``rngs[e * N + n]``). The caller owns them.
    p : float
        Flip probability, in [0, 1].

    Returns
    -------
    (..., 4, 61, 61) bool
        The reported burning value of each seen cell, per camera; False where not seen.

    Notes
    -----
    Generator ``k`` draws exactly ``seen[k].sum()`` uniforms, one per (camera, seen cell),
    camera-major then by ascending flat cell index (row-major window order is flat map
    order), and a cell flips when its uniform is < p. The draws do not depend on p, the
    truth, or any other aircraft, so an aircraft's reports for a given generator state are
    bit-identical whatever the batch.
    """
    seen = np.asarray(seen, dtype=bool)
    index, flips = report_flips(runs_of(seen), rngs, p)
    lead = seen.ndim - 3
    truth = np.asarray(truth, dtype=bool)
    cells = (*index[:lead], *index[lead + 1 :])
    reports = np.zeros(seen.shape, dtype=bool)
    reports[index] = truth[cells] ^ flips
    return reports


def report_flips(
    runs: WindowRuns, rngs: Sequence[np.random.Generator], p: float = PIXEL_ERROR
) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """Which reports flip: the seen cells of footprints ``runs`` ((..., C, rows), e.g.
    ``CameraWindows.runs``) as indices (aircraft..., camera, row, column, in the order the
    uniforms are drawn), and a bool per report, drawn as :func:`noisy_reports` says.

    No (..., 4, 61, 61) array of reports, truth or footprints is built.
    """
    if not 0.0 <= p <= 1.0:
        raise ValueError(f"p must lie in [0, 1], got {p}")
    uniforms = report_uniforms(runs, rngs)
    run, column = run_cells(runs)
    return (*run, column), uniforms < p


def report_uniforms(runs: WindowRuns, rngs: Sequence[np.random.Generator]) -> np.ndarray:
    """The uniforms of the reports of footprints ``runs`` ((..., C, rows)): aircraft by
    aircraft (C order of the leading dims, one generator each), each drawing one per seen
    cell, in the C order of (camera, row, column): the order of
    ``window_runs.run_cells``. A report flips when its uniform is below p."""
    lead = runs.first.shape[:-2]
    num_aircraft = int(np.prod(lead, dtype=np.int64))
    if len(rngs) != num_aircraft:
        raise ValueError(f"expected {num_aircraft} generators (one per aircraft), got {len(rngs)}")
    counts = runs.counts().reshape(num_aircraft, -1).sum(axis=1)
    uniforms = [rng.random(int(count)) for rng, count in zip(rngs, counts, strict=True)]
    return np.concatenate(uniforms) if uniforms else np.zeros(0)


__all__ = [
    "ALTITUDE_M",
    "CAMERA_WINDOW",
    "FOCAL_LENGTH_MM",
    "NUM_CAMERAS",
    "PITCH_DEG",
    "PIXELS_X",
    "PIXELS_Y",
    "PIXEL_ERROR",
    "RANGE_M",
    "ROLL_DEG",
    "SENSOR_X_MM",
    "SENSOR_Y_MM",
    "WINDOW_HALF",
    "CameraWindows",
    "camera_axes",
    "camera_cells",
    "camera_windows",
    "noisy_reports",
    "report_flips",
    "report_uniforms",
    "window_values",
]
