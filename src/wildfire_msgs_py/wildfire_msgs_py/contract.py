"""The topic contract: every topic of the system with its ROS 2 type and QoS, in one place.

Only standard ``common_interfaces`` types are used, so a stock ROS 2 Jazzy install can echo,
plot and record every topic. Aircraft are numbered **from 0** (``/uav0``, ``/uav1``, ...) so
that aircraft ``k`` is row ``k`` of every per-aircraft numpy array.

=========================  ==================================  ===============================
topic                      type                                QoS (reliability, durability,
                                                               depth)
=========================  ==================================  ===============================
``/clock``                 ``rosgraph_msgs/msg/Clock``         reliable, volatile, 1
``/wildfire/fire_map``     ``nav_msgs/msg/OccupancyGrid``      reliable, transient-local, 1
``/wildfire/fuel_map``     ``nav_msgs/msg/OccupancyGrid``      reliable, transient-local, 1
``/wildfire/fuel_tiles``   ``nav_msgs/msg/OccupancyGrid``      reliable, transient-local, 100
``/wildfire/belief``       ``nav_msgs/msg/OccupancyGrid``      reliable, transient-local, 1
``/wildfire/belief_age``   ``nav_msgs/msg/OccupancyGrid``      reliable, transient-local, 1
``/wildfire/score``        ``std_msgs/msg/Float64``            reliable, transient-local, 1
``/uavK/odom``             ``nav_msgs/msg/Odometry``           reliable, volatile, 10
``/uavK/bank_cmd``         ``std_msgs/msg/Float64``            reliable, volatile, 10
``/uavK/action``           ``std_msgs/msg/Int8``               reliable, transient-local, 10
``/uavK/visit``            ``nav_msgs/msg/OccupancyGrid``      reliable, transient-local, 10
``/uavK/state``            ``std_msgs/msg/Float64MultiArray``  reliable, volatile, 10
``/diagnostics``           ``diagnostic_msgs/msg/DiagnosticArray``  reliable, volatile, 100
=========================  ==================================  ===============================

System topics of the running nodes (lockstep protocol, exact agent inputs, recovery):
``/wildfire/episode`` (DiagnosticStatus), ``/wildfire/ack`` (Header),
``/wildfire/belief_age_exact`` (Image 32FC1), ``/wildfire/belief_delta`` (Int32MultiArray:
the belief between whole keyframes, ``wildfire_msgs_py.belief_delta``),
``/uavK/state_stamped`` (JointState),
``/wildfire/belief_request`` (Header), ``/wildfire/belief_snapshot`` (Float64MultiArray),
``/uavK/radio`` (UInt8MultiArray, under limited radio links);
see the entries below and ``docs/ros2_layer.md``.

Maps are latched (transient-local, depth 1) so a node or ``wildfire topic echo`` started late
still receives the current map, as with a ROS 1 latched topic. Per-aircraft streams keep 10
messages so a briefly busy subscriber loses none; visits, actions and stamped states are also
transient-local, so a subscriber whose DDS reader matched late still gets the recent ones.
The encodings of each topic are documented in :mod:`wildfire_msgs_py.codecs`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

# Map-sized grids (the fire, the fuel, the belief and its ages) have the run's geometry;
# the cell size is the contract's too (an OccupancyGrid's ``resolution``).
from wildfire_msgs_py.map_geometry import CELL_SIZE_M

if TYPE_CHECKING:
    from collections.abc import Iterator

#: Frame of every grid and pose: x east, y north, origin at the grid's south-west corner.
MAP_FRAME = "map"
#: One decision is 0.1 s: tick ``k`` is stamped ``k * DECISION_PERIOD_NS`` of sim time.
DECISION_PERIOD_NS = 100_000_000
#: Prefix of an aircraft namespace; aircraft ``k`` lives in ``/uav{k}``.
AIRCRAFT_PREFIX = "uav"


@dataclass(frozen=True)
class QosSpec:
    """Backend-neutral QoS of a topic (mapped to rclpy's or our ``QoSProfile``)."""

    depth: int = 10
    """History depth (KEEP_LAST)."""
    reliable: bool = True
    """RELIABLE when true, BEST_EFFORT otherwise."""
    transient_local: bool = False
    """TRANSIENT_LOCAL (late joiners get the last ``depth`` messages) or VOLATILE."""


LATCHED = QosSpec(depth=1, reliable=True, transient_local=True)
STREAM = QosSpec(depth=10, reliable=True, transient_local=False)
CLOCK_QOS = QosSpec(depth=1, reliable=True, transient_local=False)
#: Latched with a history, so a late joiner gets the recent per-tick messages it may need.
LATCHED_HISTORY = QosSpec(depth=10, reliable=True, transient_local=True)


@dataclass(frozen=True)
class TopicSpec:
    """One topic of the contract."""

    name: str
    """Absolute name, or for per-aircraft topics the name relative to ``/uavK``."""
    type: str
    """ROS 2 type name, ``pkg/msg/Type``."""
    qos: QosSpec
    """Quality of service both publisher and subscribers use."""
    per_aircraft: bool
    """True when one instance exists per aircraft under ``/uavK``."""
    description: str
    """What the topic carries and how it is encoded."""

    def resolve(self, aircraft: int | None = None) -> str:
        """Absolute topic name; per-aircraft topics need the aircraft index."""
        if not self.per_aircraft:
            return self.name
        if aircraft is None:
            raise ValueError(f"topic {self.name!r} is per aircraft: give the aircraft index")
        return aircraft_topic(aircraft, self.name)


CLOCK = TopicSpec(
    "/clock",
    "rosgraph_msgs/msg/Clock",
    CLOCK_QOS,
    False,
    "simulation time; lockstep mode only, published by the fire simulator",
)
FIRE_MAP = TopicSpec(
    "/wildfire/fire_map",
    "nav_msgs/msg/OccupancyGrid",
    LATCHED,
    False,
    "true fire: 100 burning, 0 not burning; 100x100 cells of 10 m, row 0 south",
)
FUEL_MAP = TopicSpec(
    "/wildfire/fuel_map",
    "nav_msgs/msg/OccupancyGrid",
    LATCHED,
    False,
    "true fuel: the integer fuel value 0..20 stored directly in each cell; whole at the "
    "start and every 40 fire steps, /wildfire/fuel_tiles between",
)
FUEL_TILES = TopicSpec(
    "/wildfire/fuel_tiles",
    "nav_msgs/msg/OccupancyGrid",
    QosSpec(depth=100, reliable=True, transient_local=True),
    False,
    "true fuel between whole fuel maps: the 32 x 32 tiles in which fuel changed in a fire "
    "step, placed by info.origin (wildfire_msgs_py.grid_tiles)",
)
BELIEF = TopicSpec(
    "/wildfire/belief",
    "nav_msgs/msg/OccupancyGrid",
    LATCHED,
    False,
    "shared belief: the probability of burning in percent, believed burning above 50 (the "
    "paper's perfect disc: 100 or 0)",
)
BELIEF_AGE = TopicSpec(
    "/wildfire/belief_age",
    "nav_msgs/msg/OccupancyGrid",
    LATCHED,
    False,
    "seconds since each cell was visited, 0..255 s scaled to 0..100 (rounded)",
)
SCORE = TopicSpec(
    "/wildfire/score",
    "std_msgs/msg/Float64",
    LATCHED,
    False,
    "cumulative team reward of the episode",
)
ODOM = TopicSpec(
    "odom",
    "nav_msgs/msg/Odometry",
    STREAM,
    True,
    "10 Hz pose: frame map, child uavK/base_link, roll = bank, yaw = heading",
)
BANK_CMD = TopicSpec(
    "bank_cmd",
    "std_msgs/msg/Float64",
    STREAM,
    True,
    "commanded bank angle in radians after each decision",
)
VISIT = TopicSpec(
    "visit",
    "nav_msgs/msg/OccupancyGrid",
    # Latched with a history: the aggregator merges tick k only once every visit of k is in,
    # and DDS discovery is not symmetric. The agent's writer can match the aggregator's reader
    # before the reader matches the writer (ROS graph counts match sooner still); a volatile
    # visit written in that gap was lost for good and the lockstep barrier waited forever.
    # Durable visits reach the aggregator whichever side matches last.
    LATCHED_HISTORY,
    True,
    "window around the aircraft: 100/0 truth in visited cells (with a pixel error: the noisy "
    "report), -1 outside the 100 m disc",
)
STATE = TopicSpec(
    "state",
    "std_msgs/msg/Float64MultiArray",
    STREAM,
    True,
    "exact aircraft state [x_m, y_m, heading_rad, bank_rad] as float64 (bit-exact for peers)",
)
#: Task name of an agent's status on ``/diagnostics``: ``uavK/agent: decision deadlines``,
#: hardware id ``uavK``.
DEADLINE_STATUS = "decision deadlines"
#: Task name of an agent's radio status under limited links: ``uavK/agent: radio links``.
RADIO_STATUS = "radio links"
DIAGNOSTICS = TopicSpec(
    "/diagnostics",
    "diagnostic_msgs/msg/DiagnosticArray",
    QosSpec(depth=100, reliable=True, transient_local=False),
    False,
    "every node's status at 1 Hz and at the end (as diagnostic_aggregator, rqt_robot_monitor "
    "and Foxglove read it): agents report decision-deadline statistics",
)

# --- system topics (lockstep protocol, exact inputs of the agents, belief recovery) ----------
#: Reliable and latched, one message per writer: the last acknowledgement of every reporter.
ACK_QOS = QosSpec(depth=1, reliable=True, transient_local=True)

ACTION = TopicSpec(
    "action",
    "std_msgs/msg/Int8",
    # Latched with a history, as state_stamped: a recorder that matches the agent a few
    # decisions late still gets the first actions (an unstamped stream is paired by count).
    LATCHED_HISTORY,
    True,
    "integer action of each decision, beside its bank_cmd: 0 = bank -5 degrees, 1 = +5 degrees "
    "(a positive bank turns left); held at the 50 degree limit",
)

EPISODE = TopicSpec(
    "/wildfire/episode",
    "diagnostic_msgs/msg/DiagnosticStatus",
    LATCHED_HISTORY,
    False,
    "episode status from the fire simulator: message waiting|running|terminated|truncated, "
    "values tick, time_s, seed, shape, wind_x, wind_y, mode (one per lockstep tick)",
)
ACK = TopicSpec(
    "/wildfire/ack",
    "std_msgs/msg/Header",
    ACK_QOS,
    False,
    "lockstep report: frame_id = reporter (uavK, belief_aggregator, ...; '<name>/ready' at "
    "start-up), stamp = sim time of the tick the reporter has finished",
)
BELIEF_AGE_EXACT = TopicSpec(
    "/wildfire/belief_age_exact",
    "sensor_msgs/msg/Image",
    LATCHED,
    False,
    "exact belief age in seconds, 32FC1, row 0 south (the ages belief policies see)",
)
BELIEF_DELTA = TopicSpec(
    "/wildfire/belief_delta",
    "std_msgs/msg/Int32MultiArray",
    LATCHED_HISTORY,
    False,
    "the shared belief between keyframes: the cells (value, exact age) that differ from the "
    "last whole /wildfire/belief and /wildfire/belief_age_exact (wildfire_msgs_py.belief_delta)",
)
STATE_STAMPED = TopicSpec(
    "state_stamped",
    "sensor_msgs/msg/JointState",
    LATCHED_HISTORY,
    True,
    "exact state with its time: name [x_m, y_m, heading_rad, bank_rad], position float64",
)
BELIEF_REQUEST = TopicSpec(
    "/wildfire/belief_request",
    "std_msgs/msg/Header",
    ACK_QOS,
    False,
    "a (re)started belief aggregator asks the agents for their copy of the shared belief",
)
BELIEF_SNAPSHOT = TopicSpec(
    "/wildfire/belief_snapshot",
    "std_msgs/msg/Float64MultiArray",
    LATCHED_HISTORY,
    False,
    "an agent's copy of the shared belief: [time_s, score, believed (rows x cols), age_s (rows x "
    "cols)], the grids' shape in the layout's rows and cols dimensions",
)
GROUND = TopicSpec(
    "/wildfire/ground",
    "std_msgs/msg/UInt8MultiArray",
    LATCHED,
    False,
    "field maps with rasters only: the run's fuel and ignition rasters, resolved (the bytes of "
    "a ground file, wildfire_sim.ground_file), once at the start by the fire simulator; every "
    "other node waits for the one whose SHA-256 is its ground_sha256",
)
RADIO = TopicSpec(
    "radio",
    "std_msgs/msg/UInt8MultiArray",
    # Durable for the reason visits are: lockstep waits for every peer's message of a tick.
    LATCHED_HISTORY,
    True,
    "the aircraft's radio message of one decision under limited links, ~90 bytes: tick, "
    "aircraft, pose and the burning bits of its visited cells (wildfire_msgs_py.radio_codec)",
)


CAMERA_CELLS: tuple[TopicSpec, ...] = tuple(
    TopicSpec(
        f"camera{i}/cells",
        "nav_msgs/msg/OccupancyGrid",
        # Durable for the reason visits are: lockstep waits for every camera's report.
        LATCHED_HISTORY,
        True,
        f"camera sensing only: what camera {i} (roll {('+40', '+13', '-13', '-40')[i]} degrees) "
        "reported this decision, 61 x 61 cells around the aircraft: 100/0 reported burning or "
        "not in the cells it saw, -1 elsewhere",
    )
    for i in range(4)
)
"""Per-camera report windows under ``--sensor camera`` (the disc's go on ``visit``)."""


def report_topics(sensor: str) -> tuple[TopicSpec, ...]:
    """The per-aircraft topics an aircraft's sensor reports on: one per camera, or ``visit``."""
    return CAMERA_CELLS if sensor == "camera" else (VISIT,)


CAMERA_FOOTPRINTS = TopicSpec(
    "camera/footprints",
    "visualization_msgs/msg/MarkerArray",
    STREAM,
    True,
    "camera sensing only: the outline of each camera's footprint this decision, one "
    "LINE_STRIP per camera in frame map (for RViz and Foxglove)",
)

#: Every topic of the contract, in documentation order.
TOPICS: tuple[TopicSpec, ...] = (
    CLOCK,
    FIRE_MAP,
    FUEL_MAP,
    FUEL_TILES,
    BELIEF,
    BELIEF_AGE,
    SCORE,
    ODOM,
    BANK_CMD,
    ACTION,
    VISIT,
    STATE,
    DIAGNOSTICS,
)
#: Topics of the running system beyond the data contract (lockstep, recovery, exact inputs).
SYSTEM_TOPICS: tuple[TopicSpec, ...] = (
    EPISODE,
    ACK,
    BELIEF_AGE_EXACT,
    BELIEF_DELTA,
    STATE_STAMPED,
    BELIEF_REQUEST,
    BELIEF_SNAPSHOT,
    GROUND,
    RADIO,
    *CAMERA_CELLS,
    CAMERA_FOOTPRINTS,
)

_AIRCRAFT_NAMESPACE = re.compile(rf"^/{AIRCRAFT_PREFIX}(0|[1-9][0-9]*)$")


def aircraft_namespace(k: int) -> str:
    """Namespace of aircraft ``k`` (0-based): ``aircraft_namespace(0) -> "/uav0"``."""
    if isinstance(k, bool) or not isinstance(k, int) or k < 0:
        raise ValueError(f"aircraft index must be an integer >= 0, got {k!r}")
    return f"/{AIRCRAFT_PREFIX}{k}"


def aircraft_topic(k: int, name: str) -> str:
    """Absolute per-aircraft topic: ``aircraft_topic(0, "odom") -> "/uav0/odom"``."""
    return f"{aircraft_namespace(k)}/{name.strip('/')}"


def aircraft_index(namespace_or_topic: str) -> int | None:
    """Aircraft index of ``/uavK`` or ``/uavK/...``; None when it is not an aircraft name."""
    parts = namespace_or_topic.split("/")
    if len(parts) < 2 or not _AIRCRAFT_NAMESPACE.match("/" + parts[1]):
        return None
    return int(parts[1][len(AIRCRAFT_PREFIX) :])


def base_link_frame(k: int) -> str:
    """Body frame of aircraft ``k``: ``uav0/base_link``."""
    return f"{AIRCRAFT_PREFIX}{k}/base_link"


def topics_for(num_aircraft: int) -> Iterator[tuple[str, TopicSpec]]:
    """Every concrete (absolute name, spec) pair of a system with ``num_aircraft`` aircraft."""
    for spec in TOPICS:
        if spec.per_aircraft:
            for k in range(num_aircraft):
                yield spec.resolve(k), spec
        else:
            yield spec.name, spec


def spec_for(topic: str) -> TopicSpec | None:
    """The contract entry of an absolute topic name (``/uav3/odom`` -> ODOM), or None."""
    every = TOPICS + SYSTEM_TOPICS
    for spec in every:
        if not spec.per_aircraft and spec.name == topic:
            return spec
    k = aircraft_index(topic)
    if k is not None:
        suffix = topic[len(aircraft_namespace(k)) + 1 :]
        for spec in every:
            if spec.per_aircraft and spec.name == suffix:
                return spec
    return None


__all__ = [
    "ACK",
    "ACK_QOS",
    "AIRCRAFT_PREFIX",
    "BANK_CMD",
    "BELIEF",
    "BELIEF_AGE",
    "BELIEF_AGE_EXACT",
    "BELIEF_DELTA",
    "BELIEF_REQUEST",
    "BELIEF_SNAPSHOT",
    "CAMERA_CELLS",
    "CAMERA_FOOTPRINTS",
    "CELL_SIZE_M",
    "CLOCK",
    "CLOCK_QOS",
    "DEADLINE_STATUS",
    "DECISION_PERIOD_NS",
    "DIAGNOSTICS",
    "EPISODE",
    "FIRE_MAP",
    "FUEL_MAP",
    "FUEL_TILES",
    "GROUND",
    "LATCHED",
    "LATCHED_HISTORY",
    "MAP_FRAME",
    "ODOM",
    "RADIO",
    "RADIO_STATUS",
    "SCORE",
    "STATE",
    "STATE_STAMPED",
    "STREAM",
    "SYSTEM_TOPICS",
    "TOPICS",
    "VISIT",
    "QosSpec",
    "TopicSpec",
    "aircraft_index",
    "aircraft_namespace",
    "aircraft_topic",
    "base_link_frame",
    "report_topics",
    "spec_for",
    "topics_for",
]
