"""Camera footprints -> ``visualization_msgs/msg/MarkerArray``, for RViz and Foxglove.

The cameras' reports travel as cell windows (``/uavK/cameraC/cells``, OccupancyGrids the
belief fuses and RViz shows as map layers). To show at a glance where each aircraft looks,
its agent also publishes the outline of each camera's footprint on
``/uavK/camera/footprints``: one closed ``LINE_STRIP`` per camera (id = camera index,
namespace ``uavK/camera``), along the outer edges of the cells it saw. A footprint is convex,
so each row of cells is one run and the outline is the runs' west ends going north, then
their east ends going south: about 50 points a camera, not one per cell (a marker per cell
cost 35 ms a decision in Python message objects). Each decision's markers replace the
previous ones (same namespace and ids).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from wildfire_msgs_py.codecs import VisitWindow, _message, _set_stamp
from wildfire_msgs_py.contract import CELL_SIZE_M, MAP_FRAME, aircraft_namespace
from wildfire_msgs_py.messages import get_message

LINE_STRIP = 4
"""``visualization_msgs/msg/Marker`` type of a polyline."""
LINE_WIDTH_M = 3.0
CAMERA_RGBA = (
    (0.12, 0.47, 0.71, 1.0),
    (0.17, 0.63, 0.17, 1.0),
    (0.58, 0.40, 0.74, 1.0),
    (0.09, 0.75, 0.81, 1.0),
)
"""One colour per camera, left outer to right outer."""


def footprint_outline(window: VisitWindow) -> np.ndarray:
    """The closed outline (K, 2) of the cells ``window.visited`` marks, in map metres (x, y);
    empty when the camera saw nothing."""
    seen = np.asarray(window.visited, dtype=bool)
    rows = np.flatnonzero(seen.any(axis=1))
    if rows.size == 0:
        return np.zeros((0, 2))
    west = seen[rows].argmax(axis=1)
    east = seen.shape[1] - seen[rows][:, ::-1].argmax(axis=1)
    south = (window.row0 + rows) * CELL_SIZE_M
    north = south + CELL_SIZE_M
    # Each row contributes its two corners on each side, so steps between rows stay square.
    west_x = np.repeat((window.col0 + west) * CELL_SIZE_M, 2)
    east_x = np.repeat((window.col0 + east) * CELL_SIZE_M, 2)
    side_y = np.stack([south, north], axis=1).reshape(-1)
    left = np.stack([west_x, side_y], axis=1)
    right = np.stack([east_x, side_y], axis=1)[::-1]
    return np.concatenate([left, right, left[:1]])


def footprints_to_msg(windows: Sequence[VisitWindow], aircraft: int, stamp: Any = 0) -> Any:
    """The footprints of one decision (one report window per camera) -> MarkerArray."""
    array = _message("visualization_msgs/msg/MarkerArray")
    point = get_message("geometry_msgs/msg/Point")  # once: a lookup per point costs more
    namespace = aircraft_namespace(aircraft).strip("/") + "/camera"
    markers = []
    for c, window in enumerate(windows):
        marker = _message("visualization_msgs/msg/Marker")
        _set_stamp(marker.header, stamp, MAP_FRAME)
        marker.ns, marker.id, marker.type = namespace, c, LINE_STRIP
        marker.pose.orientation.w = 1.0
        marker.scale.x = LINE_WIDTH_M
        color = marker.color
        color.r, color.g, color.b, color.a = CAMERA_RGBA[c % len(CAMERA_RGBA)]
        marker.points = [point(x=x, y=y) for x, y in footprint_outline(window).tolist()]
        markers.append(marker)
    array.markers = markers
    return array


def outlines_from_msg(msg: Any) -> list[np.ndarray]:
    """MarkerArray -> each marker's outline (K, 2) in map metres (for tests and tools)."""
    return [
        np.array([[p.x, p.y] for p in marker.points], dtype=np.float64).reshape(-1, 2)
        for marker in msg.markers
    ]


__all__ = [
    "CAMERA_RGBA",
    "LINE_STRIP",
    "footprint_outline",
    "footprints_to_msg",
    "outlines_from_msg",
]
