"""What one aircraft's sensor reports each decision, as windows of the map.

The paper's perfect disc reports the truth of every cell within 100 m: one visit window.
Under noisy sensing (``--sensor camera``, or any ``--pixel-error``) each sensor (the four
cameras, or the disc) reports its seen cells, each flipped with probability p from the
aircraft's own stream (``Stream.SENSOR``, aircraft k): one window per sensor, in camera
order. The environment draws the same numbers for aircraft k of the same seed
(``wildfire_world.team_sensing``), so the reports on the wire are the environment's.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from wildfire_agent import camera
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_belief import sensors
from wildfire_belief.visits import visit_windows, window_values
from wildfire_belief.window_runs import WindowRuns, runs_of
from wildfire_msgs_py.codecs import VisitWindow
from wildfire_sim.grid import PAPER_MAP, MapGeometry, geometry_of
from wildfire_sim.seeding import Stream, generator


def check_sensing(sensor: str, pixel_error: float) -> None:
    """Refuse an unknown sensor or a pixel error outside [0, 0.5) (one line)."""
    try:
        sensors.check_sensing(sensor, pixel_error)
    except ValueError as error:
        raise AgentConfigError(str(error)) from None


def visit_window(state: AircraftState, burning: np.ndarray) -> VisitWindow:
    """The perfect disc: the cells the aircraft at ``state`` (fields (1,)) visits, with their
    true fire state in the (H, W) ``burning``."""
    windows = visit_windows(state.x_m[None], state.y_m[None], geometry_of(burning))
    truth = window_values(burning[None], windows)[0, 0].astype(bool)
    return VisitWindow(
        int(windows.row0[0, 0]), int(windows.col0[0, 0]), windows.visited[0, 0], truth
    )


class SensorWindows(NamedTuple):
    """What every aircraft's sensor sees this decision: windows of cells around it."""

    row0: np.ndarray
    """(E, N) row of each window's south-west cell (may lie off the map)."""
    col0: np.ndarray
    """(E, N) column of that cell."""
    runs: WindowRuns
    """(E, N, C, rows): the cells each sensor C (cameras, or 1 disc) sees, row by row."""


def sensor_windows(
    sensor: str, pose: AircraftState, geometry: MapGeometry = PAPER_MAP
) -> SensorWindows:
    """The windows of ``sensor`` for aircraft at ``pose`` (fields (E, N)) on ``geometry``."""
    if sensor == "camera":
        cameras = camera.camera_windows(
            pose.x_m, pose.y_m, pose.heading_rad, pose.bank_steps, geometry
        )
        return SensorWindows(cameras.row0, cameras.col0, cameras.runs)
    disc = visit_windows(pose.x_m, pose.y_m, geometry)
    return SensorWindows(disc.row0, disc.col0, runs_of(disc.visited[:, :, None]))


class AircraftSensor:
    """Sensor of aircraft ``k`` in episode ``seed``."""

    def __init__(self, sensor: str, pixel_error: float, seed: int, k: int) -> None:
        check_sensing(sensor, pixel_error)
        self.sensor = sensor
        self.pixel_error = pixel_error
        self.noisy = sensors.noisy(sensor, pixel_error)
        self.rng = generator(seed, Stream.SENSOR, k) if self.noisy else None
        if self.noisy:
            # The reports' and footprints' compiled loops (numba and its cached kernels),
            # loaded now, before the run, not in the first real-time decision.
            from wildfire_agent import camera_kernels
            from wildfire_belief import belief_kernels

            belief_kernels.compile_kernels()
            camera_kernels.compile_kernels()

    def report(self, state: AircraftState, burning: np.ndarray) -> tuple[VisitWindow, ...]:
        """The windows of one decision at ``state`` (fields (1,)) over the (H, W) truth.

        Call it once per decision, in order: each call draws the decision's flips.
        """
        if self.rng is None:
            return (visit_window(state, burning),)
        x, y, geometry = state.x_m[None], state.y_m[None], geometry_of(burning)
        if self.sensor == "camera":
            heading, bank = state.heading_rad[None], state.bank_steps[None]
            cameras = camera.camera_windows(x, y, heading, bank, geometry=geometry)
            truth = camera.window_values(burning[None], cameras)
            row0, col0, seen = cameras.row0, cameras.col0, cameras.seen
        else:
            disc = visit_windows(x, y, geometry)
            truth = window_values(burning[None], disc)
            row0, col0, seen = disc.row0, disc.col0, disc.visited[:, :, None]
        reports = camera.noisy_reports(truth, seen, [self.rng], self.pixel_error)[0, 0]
        return tuple(
            VisitWindow(int(row0[0, 0]), int(col0[0, 0]), seen[0, 0, c], reports[c])
            for c in range(seen.shape[2])
        )


__all__ = ["AircraftSensor", "SensorWindows", "check_sensing", "sensor_windows", "visit_window"]
