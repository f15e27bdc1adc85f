"""Launch the wildfire system: ``ros2 launch wildfire_bringup wildfire_launch.py n_aircraft:=3``.

Real-time mode (wall clocks): the fire simulator, the belief aggregator and one agent per
aircraft in namespaces ``/uav0`` ... Start poses are spread on a circle around the map
centre; parameters come from ``config/wildfire.yaml`` of this package. (``wildfire run``
draws start poses from the seed and offers lockstep mode.) ``foxglove:=8765`` adds the
Foxglove live view on that 127.0.0.1 port. ``agents_per_process:=K`` composes the agents, at
most K to a process (``agent_group``, one ``--node`` section per agent), by the rule of
``wildfire run --agents-per-process`` (:mod:`wildfire_bringup.agent_processes`); left empty,
one agent per process up to 8 aircraft. ``map_size:=R,C`` and ``ignitions:=K`` fly a field
map (every node gets the ground parameters of ``wildfire_sim.ground_parameters``);
``ground_file:=PATH`` adds fuel and ignition rasters, resolved (the ``ground.npz`` that
``wildfire run --fuel-map ... --log-dir D`` writes to D; ``wildfire_sim.ground_file``).
"""

from __future__ import annotations

import hashlib
import math
import os
import sys

from ament_index_python.packages import get_package_share_directory

from wildfire_bringup.agent_processes import agent_groups
from wildfire_ros.node_support import NODE_SECTION

try:
    from launch.actions import DeclareLaunchArgument, OpaqueFunction
    from launch.substitutions import LaunchConfiguration
    from launch_ros.actions import Node

    from launch import LaunchDescription
except ImportError:
    # The pip wheels of ROS 2 Jazzy (rclpy, common_interfaces) carry no launch system.
    print(
        "wildfire_launch.py: needs ROS 2 launch (a full ROS 2 Jazzy install, `ros2 launch`); "
        "without it, start the system with `wildfire run`",
        file=sys.stderr,
    )
    raise SystemExit(2) from None


def _ros_value(value):
    """A ``-p`` value as ``wildfire run`` writes it (floats in full, bools lower case)."""
    if isinstance(value, float):
        return repr(value)
    return str(value).lower() if isinstance(value, bool) else str(value)


def _composed(group, params, values):
    """One ``agent_group`` process for the aircraft of ``group`` (``values[k]``: agent k's)."""
    arguments = []
    for k in group:
        arguments += [NODE_SECTION, "--ros-args", "--params-file", params, "-r", f"__ns:=/uav{k}"]
        for name, value in values[k].items():
            arguments += ["-p", f"{name}:={_ros_value(value)}"]
    return Node(
        package="wildfire_agent", executable="agent_group", arguments=arguments, output="screen"
    )


def _nodes(context, *_args, **_kwargs):
    n = int(LaunchConfiguration("n_aircraft").perform(context))
    policy = LaunchConfiguration("policy").perform(context)
    seed = int(LaunchConfiguration("seed").perform(context))
    params = os.path.join(
        get_package_share_directory("wildfire_bringup"), "config", "wildfire.yaml"
    )
    rows, cols = (int(v) for v in LaunchConfiguration("map_size").perform(context).split(","))
    ignitions = int(LaunchConfiguration("ignitions").perform(context))
    ground_file = LaunchConfiguration("ground_file").perform(context)
    ground = {"map_rows": rows, "map_cols": cols, "ignitions": ignitions}
    reader = {}  # the fire simulator reads the rasters; the others wait for them on the wire
    if ground_file:
        with open(ground_file, "rb") as raw:
            ground["ground_sha256"] = hashlib.sha256(raw.read()).hexdigest()
        reader = {"ground_file": os.path.abspath(ground_file)}
    common = {"mode": "realtime", "seed": seed, **ground}
    nodes = [
        Node(
            package="wildfire_sim",
            executable="fire_simulator",
            name="fire_simulator",
            parameters=[params, {**common, **reader, "n_aircraft": n}],
            output="screen",
        ),
        Node(
            package="wildfire_belief",
            executable="belief_aggregator",
            name="belief_aggregator",
            parameters=[params, {**common, "n_aircraft": n}],
            output="screen",
        ),
    ]
    values = {}
    for k in range(n):
        bearing = 2.0 * math.pi * k / n
        values[k] = {
            **common,
            "aircraft": k,
            "n_aircraft": n,
            "policy": policy,
            "start_x": 5.0 * cols + 250.0 * math.cos(bearing),  # the map's centre is 5 m/cell
            "start_y": 5.0 * rows + 250.0 * math.sin(bearing),
            "start_heading": bearing + math.pi / 2,
        }
    per_process = LaunchConfiguration("agents_per_process").perform(context)
    for group in agent_groups(n, int(per_process) if per_process else None):
        if len(group) > 1:
            nodes.append(_composed(group, params, values))
            continue
        nodes.append(
            Node(
                package="wildfire_agent",
                executable="agent",
                name="agent",
                namespace=f"uav{group[0]}",
                output="screen",
                parameters=[params, values[group[0]]],
            )
        )
    port = LaunchConfiguration("foxglove").perform(context)
    if port:
        nodes.append(
            Node(
                package="wildfire_bringup",
                executable="live_view",
                name="live_view",
                parameters=[
                    {"port": int(port), "n_aircraft": n, "map_rows": rows, "map_cols": cols}
                ],
                output="screen",
            )
        )
    return nodes


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "n_aircraft", default_value="2", description="number of aircraft"
            ),
            DeclareLaunchArgument(
                "policy",
                default_value="rh",
                description="rh, rh-paper, random or the path of a TorchScript .pt policy",
            ),
            DeclareLaunchArgument("seed", default_value="0", description="episode seed"),
            DeclareLaunchArgument(
                "map_size", default_value="100,100", description="ROWS,COLS cells of 10 m"
            ),
            DeclareLaunchArgument(
                "ignitions",
                default_value="0",
                description="seeded 5 x 5 ignitions (0: the shape at the map's centre)",
            ),
            DeclareLaunchArgument(
                "ground_file",
                default_value="",
                description="fuel and ignition rasters resolved by wildfire run (its log "
                "folder's ground.npz; empty: none)",
            ),
            DeclareLaunchArgument(
                "agents_per_process",
                default_value="",
                description="agent nodes per process, at most (composed agents; empty: one per "
                "process up to 8 aircraft, at most 8 agent processes above)",
            ),
            DeclareLaunchArgument(
                "foxglove",
                default_value="",
                description="serve the run to Foxglove on this 127.0.0.1 port (empty: not)",
            ),
            OpaqueFunction(function=_nodes),
        ]
    )
