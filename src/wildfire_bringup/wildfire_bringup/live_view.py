"""The live view's core: the run's messages -> Foxglove's well-known messages, on typed channels.

No ROS import: the inputs are the contract's messages read by attribute (``nav_msgs``
OccupancyGrid and Odometry, ``visualization_msgs`` MarkerArray, the score as a float), so the
node that feeds them (:mod:`wildfire_bringup.live_view_node`) only subscribes and calls.

Channels, as a Foxglove client sees them (every message stamped with the run's sim time):

===============================  ========================  ==================================
channel                          schema                    what
===============================  ========================  ==================================
``/wildfire/fire_map``           ``foxglove.Grid``         truth, field ``burning`` 0 or 100
``/wildfire/belief``             ``foxglove.Grid``         field ``probability``, percent
``/wildfire/belief_age``         ``foxglove.Grid``         field ``age``, 0..255 s as 0..100
``/wildfire/aircraft``           ``foxglove.SceneUpdate``  an arrow per aircraft and its path
``/wildfire/camera_footprints``  ``foxglove.SceneUpdate``  each camera's outline (camera only)
``/tf``                          ``foxglove.FrameTransforms``  ``map`` -> ``uavK/base_link``
``/wildfire/score``              ``wildfire.Score`` (JSON)  ``score`` and ``time_s``, to plot
===============================  ========================  ==================================

The fire grid takes its size, cell size and origin from the message it converts
(``info.width``/``height``/``resolution``/``origin``), so any map size shows as it is. The
belief and its ages show every tick: the node mirrors the belief's keyframes (one a fire
step) and the deltas between (:mod:`wildfire_msgs_py.belief_inputs`) and logs each whole
frame the mirror completes, placed as the contract places its maps.
The score is one number, for which Foxglove has no well-known message: a JSON channel with a
two-field schema.

**No client, no cost**: :meth:`LiveView.wanted` names the run's topics that feed a channel
some client subscribed to, and the node subscribes to those only: with no client it receives
nothing at all. The maps and the score are latched, so a new subscription gets the latest at
once; a path shows the flight since its channel was first watched (a point per aircraft
every :data:`PATH_PERIOD_NS` of sim time). Logging never waits: the server keeps a bounded
backlog per client and drops the oldest message of a slow one.
"""

from __future__ import annotations

import json
import math
from collections import Counter, deque
from typing import TYPE_CHECKING, Any

import foxglove
import numpy as np
from foxglove.channels import FrameTransformsChannel, GridChannel, SceneUpdateChannel
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    FrameTransform,
    FrameTransforms,
    Grid,
    LinePrimitive,
    PackedElementField,
    PackedElementFieldNumericType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    TextPrimitive,
    Timestamp,
    Vector2,
    Vector3,
)

from wildfire_msgs_py.belief_delta import Frame
from wildfire_msgs_py.codecs import belief_age_display, grid_from_msg, odometry_to_pose
from wildfire_msgs_py.contract import (
    BELIEF,
    BELIEF_AGE,
    BELIEF_AGE_EXACT,
    BELIEF_DELTA,
    CAMERA_FOOTPRINTS,
    FIRE_MAP,
    MAP_FRAME,
    ODOM,
    SCORE,
    aircraft_namespace,
    base_link_frame,
)
from wildfire_msgs_py.map_geometry import CELL_SIZE_M

if TYPE_CHECKING:
    from collections.abc import Sequence

    from foxglove.websocket import WebSocketServer

DEFAULT_PORT = 8765
"""Foxglove's usual WebSocket port."""
HOST = "127.0.0.1"
"""The server listens on loopback only (view from elsewhere through an SSH tunnel)."""

AIRCRAFT_CHANNEL = "/wildfire/aircraft"
FOOTPRINTS_CHANNEL = "/wildfire/camera_footprints"
TF_CHANNEL = "/tf"
SCORE_CHANNEL = "/wildfire/score"
GRID_FIELDS = {FIRE_MAP.name: "burning", BELIEF.name: "probability", BELIEF_AGE.name: "age"}
"""Grid channel -> the name of its one int8 field (the OccupancyGrid's value)."""
BELIEF_FEEDS = (BELIEF.name, BELIEF_AGE_EXACT.name, BELIEF_DELTA.name)
"""What the belief's two channels are fed from: its keyframes and the deltas between, so
that they show every tick's belief (:meth:`LiveView.belief_frame`), not one a fire step."""
SCORE_SCHEMA = {
    "title": "wildfire.Score",
    "type": "object",
    "properties": {
        "score": {"type": "number", "description": "cumulative team reward of the episode"},
        "time_s": {"type": "number", "description": "sim time of the latest message, s"},
    },
}

PATH_PERIOD_NS = 500_000_000
"""A path keeps one point per aircraft every 0.5 s of sim time (5 decisions)."""
PATH_POINTS = 1000
"""Most points a path keeps (500 s at one point per 0.5 s: the longest episode is 400 s)."""
AIRCRAFT_Z_M = 5.0
"""Height the aircraft and paths are drawn at, above the grids (at 0) and footprints."""
FOOTPRINT_Z_M = 2.0
PALETTE = (
    (0.12, 0.47, 0.71),
    (1.00, 0.50, 0.05),
    (0.17, 0.63, 0.17),
    (0.84, 0.15, 0.16),
    (0.58, 0.40, 0.74),
    (0.55, 0.34, 0.29),
    (0.89, 0.47, 0.76),
    (0.50, 0.50, 0.50),
)
"""One colour per aircraft (``k % 8``), as matplotlib's tab10."""


def timestamp(stamp_ns: int) -> Timestamp:
    """Integer nanoseconds -> Foxglove's Timestamp."""
    sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
    return Timestamp(sec, nsec)


def stamp_of(header: Any) -> int:
    """A ``std_msgs/Header``'s stamp in nanoseconds."""
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _translation(ros_pose: Any) -> Vector3:
    p = ros_pose.position
    return Vector3(x=float(p.x), y=float(p.y), z=float(p.z))


def _rotation(ros_pose: Any) -> Quaternion:
    q = ros_pose.orientation
    return Quaternion(x=float(q.x), y=float(q.y), z=float(q.z), w=float(q.w))


def _pose(ros_pose: Any) -> Pose:
    # foxglove-sdk messages are write-only: the parts are built, never read back.
    return Pose(position=_translation(ros_pose), orientation=_rotation(ros_pose))


def _level(yaw_rad: float) -> Quaternion:
    """The heading alone (no bank): arrows stay flat on the map."""
    return Quaternion(z=math.sin(yaw_rad / 2.0), w=math.cos(yaw_rad / 2.0))


def _color(k: int, alpha: float = 1.0) -> Color:
    r, g, b = PALETTE[k % len(PALETTE)]
    return Color(r=r, g=g, b=b, a=alpha)


def grid_from_occupancy(msg: Any, field: str) -> Grid:
    """``nav_msgs/OccupancyGrid`` -> ``foxglove.Grid`` with one int8 field named ``field``.

    Both store rows south to north from the origin corner (Foxglove: "row-major, y-major"),
    so the data bytes go over as they are; the size and pose are the message's own. A grid
    whose data does not fill width x height raises :class:`MessageFieldError`.
    """
    info = msg.info
    return _int8_grid(
        grid_from_msg(msg),
        stamp_of(msg.header),
        field,
        frame_id=msg.header.frame_id or MAP_FRAME,
        pose=_pose(info.origin),
        resolution=float(info.resolution),
    )


def map_grid(values: np.ndarray, stamp_ns: int, field: str) -> Grid:
    """A whole map's int8 ``[row, col]`` values -> ``foxglove.Grid``, placed as the contract
    places its maps (origin at the map's south-west corner, 10 m cells, frame ``map``)."""
    pose = Pose(position=Vector3(x=0.0, y=0.0, z=0.0), orientation=_level(0.0))
    return _int8_grid(values, stamp_ns, field, frame_id=MAP_FRAME, pose=pose)


def _int8_grid(
    values: np.ndarray,
    stamp_ns: int,
    field: str,
    *,
    frame_id: str,
    pose: Pose,
    resolution: float = CELL_SIZE_M,
) -> Grid:
    width = int(values.shape[1])
    return Grid(
        timestamp=timestamp(stamp_ns),
        frame_id=frame_id,
        pose=pose,
        column_count=width,
        cell_size=Vector2(x=resolution, y=resolution),
        row_stride=width,
        cell_stride=1,
        fields=[PackedElementField(name=field, offset=0, type=PackedElementFieldNumericType.Int8)],
        data=np.ascontiguousarray(values, dtype=np.int8).tobytes(),
    )


def aircraft_entity(k: int, odom: Any) -> SceneEntity:
    """Aircraft ``k`` at its odometry pose: a flat arrow along its heading and its name."""
    x_m, y_m, heading_rad, _ = odometry_to_pose(odom)
    pose = Pose(position=Vector3(x=x_m, y=y_m, z=AIRCRAFT_Z_M), orientation=_level(heading_rad))
    name = aircraft_namespace(k).strip("/")
    return SceneEntity(
        timestamp=timestamp(stamp_of(odom.header)),
        frame_id=MAP_FRAME,
        id=name,
        arrows=[
            ArrowPrimitive(
                pose=pose,
                shaft_length=24.0,
                shaft_diameter=6.0,
                head_length=16.0,
                head_diameter=16.0,
                color=_color(k),
            )
        ],
        texts=[
            TextPrimitive(
                pose=Pose(position=Vector3(x=x_m, y=y_m, z=AIRCRAFT_Z_M + 15.0)),
                billboard=True,
                font_size=14.0,
                scale_invariant=True,
                color=_color(k),
                text=name,
            )
        ],
    )


def path_entity(k: int, points: Sequence[tuple[float, float]], stamp_ns: int) -> SceneEntity:
    """Aircraft ``k``'s path so far, one line through ``points`` (map metres)."""
    return SceneEntity(
        timestamp=timestamp(stamp_ns),
        frame_id=MAP_FRAME,
        id=aircraft_namespace(k).strip("/") + "/path",
        lines=[
            LinePrimitive(
                thickness=2.0,
                points=[Point3(x=x, y=y, z=AIRCRAFT_Z_M) for x, y in points],
                color=_color(k, 0.8),
            )
        ],
    )


def footprints_entity(k: int, markers: Any) -> SceneEntity:
    """``visualization_msgs/MarkerArray`` of aircraft ``k``'s camera outlines -> one entity,
    one closed line per camera with the marker's colour and width."""
    lines = []
    stamp_ns = 0
    for marker in markers.markers:
        stamp_ns = max(stamp_ns, stamp_of(marker.header))
        c = marker.color
        lines.append(
            LinePrimitive(
                thickness=float(marker.scale.x),
                points=[Point3(x=float(q.x), y=float(q.y), z=FOOTPRINT_Z_M) for q in marker.points],
                color=Color(r=float(c.r), g=float(c.g), b=float(c.b), a=float(c.a)),
            )
        )
    return SceneEntity(
        timestamp=timestamp(stamp_ns),
        frame_id=MAP_FRAME,
        id=aircraft_namespace(k).strip("/") + "/camera",
        lines=lines,
    )


def body_transform(k: int, odom: Any) -> FrameTransform:
    """``map`` -> ``uavK/base_link`` from an odometry message (so a view can follow one)."""
    return FrameTransform(
        timestamp=timestamp(stamp_of(odom.header)),
        parent_frame_id=MAP_FRAME,
        child_frame_id=base_link_frame(k),
        translation=_translation(odom.pose.pose),
        rotation=_rotation(odom.pose.pose),
    )


class PathHistory:
    """Each aircraft's path: a point every :data:`PATH_PERIOD_NS`, at most :data:`PATH_POINTS`."""

    def __init__(self) -> None:
        self.points: dict[int, deque[tuple[float, float]]] = {}
        self.last_ns: dict[int, int] = {}

    def add(self, k: int, x_m: float, y_m: float, stamp_ns: int) -> bool:
        """Record the pose if a period has passed since the last point; True if it did."""
        last = self.last_ns.get(k)
        if last is not None and stamp_ns - last < PATH_PERIOD_NS:
            return False
        self.points.setdefault(k, deque(maxlen=PATH_POINTS)).append((x_m, y_m))
        self.last_ns[k] = stamp_ns
        return True

    def clear(self) -> None:
        """Forget every path."""
        self.points.clear()
        self.last_ns.clear()


class LiveView:
    """The live view's channels in one Foxglove context, and what to log on each."""

    def __init__(self, context: foxglove.Context | None = None) -> None:
        self.context = context or foxglove.Context()
        self.grids = {topic: GridChannel(topic, context=self.context) for topic in GRID_FIELDS}
        self.aircraft = SceneUpdateChannel(AIRCRAFT_CHANNEL, context=self.context)
        self.footprints = SceneUpdateChannel(FOOTPRINTS_CHANNEL, context=self.context)
        self.transforms = FrameTransformsChannel(TF_CHANNEL, context=self.context)
        self.score_channel = foxglove.Channel(
            SCORE_CHANNEL, schema=SCORE_SCHEMA, context=self.context
        )
        self.paths = PathHistory()
        self.clock_ns = 0
        """Sim time of the newest stamped message: the score's stamp (a Float64 has none)."""
        self.logged: Counter[str] = Counter()
        """Messages logged, by channel (none while no client listens)."""

    def start_server(self, port: int) -> WebSocketServer:
        """Serve the channels on ``ws://127.0.0.1:port`` (port 0: any free one)."""
        return foxglove.start_server(name="wildfire", host=HOST, port=port, context=self.context)

    def wanted(self) -> set[str]:
        """The run's topics that feed a channel a client subscribed to (``odom`` and
        ``camera/footprints`` for every aircraft): what the node subscribes to now."""
        topics = {FIRE_MAP.name} if self.grids[FIRE_MAP.name].has_sinks() else set()
        if self.grids[BELIEF.name].has_sinks() or self.grids[BELIEF_AGE.name].has_sinks():
            topics.update(BELIEF_FEEDS)
        if self.score_channel.has_sinks():
            topics.add(SCORE.name)
        if self.aircraft.has_sinks() or self.transforms.has_sinks():
            topics.add(ODOM.name)
        else:
            self.paths.clear()  # unwatched: the next watcher's paths start when it does
        if self.footprints.has_sinks():
            topics.add(CAMERA_FOOTPRINTS.name)
        return topics

    def _tick(self, stamp_ns: int) -> None:
        self.clock_ns = max(self.clock_ns, stamp_ns)

    def belief_frame(self, frame: Frame) -> bool:
        """One tick's whole belief (rebuilt from its keyframe and delta) on the belief and
        age channels that a client watches; True if logged."""
        self._tick(frame.stamp)
        logged = False
        for topic in (BELIEF.name, BELIEF_AGE.name):
            channel = self.grids[topic]
            if channel.has_sinks():
                values = frame.grid if topic == BELIEF.name else belief_age_display(frame.age_s)
                channel.log(map_grid(values, frame.stamp, GRID_FIELDS[topic]), log_time=frame.stamp)
                self.logged[topic] += 1
                logged = True
        return logged

    def grid(self, topic: str, msg: Any) -> bool:
        """Log a map message (the fire's) on its grid channel; True if logged."""
        stamp_ns = stamp_of(msg.header)
        self._tick(stamp_ns)
        channel = self.grids[topic]
        if not channel.has_sinks():
            return False
        channel.log(grid_from_occupancy(msg, GRID_FIELDS[topic]), log_time=stamp_ns)
        self.logged[topic] += 1
        return True

    def odometry(self, k: int, msg: Any) -> bool:
        """Aircraft ``k``'s pose: its path always, its arrow and frame when watched."""
        stamp_ns = stamp_of(msg.header)
        self._tick(stamp_ns)
        position = msg.pose.pose.position
        moved = self.paths.add(k, float(position.x), float(position.y), stamp_ns)
        logged = False
        if self.transforms.has_sinks():
            self.transforms.log(
                FrameTransforms(transforms=[body_transform(k, msg)]), log_time=stamp_ns
            )
            self.logged[TF_CHANNEL] += 1
            logged = True
        if self.aircraft.has_sinks():
            entities = [aircraft_entity(k, msg)]
            if moved:  # the path only changes every PATH_PERIOD_NS: send it then
                entities.append(path_entity(k, self.paths.points[k], stamp_ns))
            self.aircraft.log(SceneUpdate(entities=entities), log_time=stamp_ns)
            self.logged[AIRCRAFT_CHANNEL] += 1
            logged = True
        return logged

    def camera_footprints(self, k: int, msg: Any) -> bool:
        """Aircraft ``k``'s camera outlines of one decision; True if logged."""
        if not self.footprints.has_sinks():
            return False
        stamp_ns = max((stamp_of(m.header) for m in msg.markers), default=self.clock_ns)
        self.footprints.log(SceneUpdate(entities=[footprints_entity(k, msg)]), log_time=stamp_ns)
        self.logged[FOOTPRINTS_CHANNEL] += 1
        return True

    def score(self, value: float) -> bool:
        """The cumulative score, stamped with the newest sim time seen; True if logged."""
        if not self.score_channel.has_sinks():
            return False
        message = {"score": float(value), "time_s": self.clock_ns / 1e9}
        self.score_channel.log(json.dumps(message).encode(), log_time=self.clock_ns)
        self.logged[SCORE_CHANNEL] += 1
        return True

    def close(self) -> None:
        """Unadvertise every channel."""
        for grid in self.grids.values():
            grid.close()
        self.aircraft.close()
        self.footprints.close()
        self.transforms.close()
        self.score_channel.close()


__all__ = [
    "AIRCRAFT_CHANNEL",
    "BELIEF_FEEDS",
    "DEFAULT_PORT",
    "FOOTPRINTS_CHANNEL",
    "GRID_FIELDS",
    "HOST",
    "PATH_PERIOD_NS",
    "SCORE_CHANNEL",
    "TF_CHANNEL",
    "LiveView",
    "PathHistory",
    "aircraft_entity",
    "body_transform",
    "footprints_entity",
    "grid_from_occupancy",
    "map_grid",
    "path_entity",
    "stamp_of",
    "timestamp",
]
