"""The sensors a team may fly, as the belief sees them: their names, how many report
windows each aircraft sends per decision, and how large those windows are.

The geometry of the cameras is ``wildfire_agent.camera``; the belief only needs to know
which windows to wait for and fuse.
"""

from __future__ import annotations

from wildfire_belief.visits import VISIT_WINDOW

SENSORS = ("disc", "camera")
"""The paper's perfect 100 m disc, or the four cameras of the authors' follow-up."""
NUM_CAMERAS = 4
CAMERA_WINDOW_HALF = 30
"""Cells from the aircraft's cell to a camera window's edge: a centre 31 cells off is more
than the cameras' 300 m range away."""
CAMERA_WINDOW = 2 * CAMERA_WINDOW_HALF + 1
"""Edge of a camera's report window in cells."""


def check_sensing(sensor: str, pixel_error: float, wind_filter: bool = False) -> None:
    """Refuse an unknown sensor, a pixel error outside [0, 0.5) (ValueError, one line: at
    0.5 a report says nothing), or a wind filter without noisy reports (its particles are
    weighted by how likely each report is: a certain report rules every particle out)."""
    if sensor not in SENSORS:
        raise ValueError(f"sensor {sensor!r}: expected one of {', '.join(SENSORS)}")
    if not 0.0 <= pixel_error < 0.5:
        raise ValueError(f"pixel_error {pixel_error}: expected 0 <= p < 0.5")
    if wind_filter and not pixel_error > 0.0:
        raise ValueError("wind_filter: expected noisy reports (pixel_error > 0)")


def noisy(sensor: str, pixel_error: float) -> bool:
    """Whether the team keeps the filtered belief (anything but the perfect disc)."""
    return sensor != "disc" or pixel_error > 0.0


def sensing_text(sensor: str, pixel_error: float) -> str:
    """A run's sensing as one string, e.g. ``camera,0.1`` (what a bag records)."""
    return f"{sensor},{pixel_error!r}"


def parse_sensing(text: str) -> tuple[str, float]:
    """:func:`sensing_text` back to (sensor, pixel error); ValueError if it is not one."""
    sensor, _, error = text.partition(",")
    sensing = sensor, float(error or 0.0)
    check_sensing(*sensing)
    return sensing


def sensors_of(sensor: str) -> int:
    """Report windows per aircraft and decision: one per camera, or the one disc."""
    return NUM_CAMERAS if sensor == "camera" else 1


def report_window(sensor: str) -> int:
    """Edge, in cells, of each report window of ``sensor``."""
    return CAMERA_WINDOW if sensor == "camera" else VISIT_WINDOW


__all__ = [
    "CAMERA_WINDOW",
    "CAMERA_WINDOW_HALF",
    "NUM_CAMERAS",
    "SENSORS",
    "check_sensing",
    "noisy",
    "parse_sensing",
    "report_window",
    "sensing_text",
    "sensors_of",
]
