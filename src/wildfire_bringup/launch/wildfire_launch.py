"""Launch the wildfire system: ``ros2 launch wildfire_bringup wildfire_launch.py n_aircraft:=3``.

Real-time mode (wall clocks): the fire simulator, the belief aggregator and one agent per
aircraft in namespaces ``/uav0`` ... Start poses are spread on a circle around the map
centre; parameters come from ``config/wildfire.yaml`` of this package. (``wildfire run``
draws start poses from the seed and offers lockstep mode.) ``foxglove:=8765`` adds the
Foxglove live view on that 127.0.0.1 port.
"""

from __future__ import annotations

import math
import os
import sys

from ament_index_python.packages import get_package_share_directory

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


def _nodes(context, *_args, **_kwargs):
    n = int(LaunchConfiguration("n_aircraft").perform(context))
    policy = LaunchConfiguration("policy").perform(context)
    seed = int(LaunchConfiguration("seed").perform(context))
    params = os.path.join(
        get_package_share_directory("wildfire_bringup"), "config", "wildfire.yaml"
    )
    common = {"mode": "realtime", "seed": seed}
    nodes = [
        Node(
            package="wildfire_sim",
            executable="fire_simulator",
            name="fire_simulator",
            parameters=[params, {**common, "n_aircraft": n}],
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
    for k in range(n):
        bearing = 2.0 * math.pi * k / n
        nodes.append(
            Node(
                package="wildfire_agent",
                executable="agent",
                name="agent",
                namespace=f"uav{k}",
                output="screen",
                parameters=[
                    params,
                    {
                        **common,
                        "aircraft": k,
                        "n_aircraft": n,
                        "policy": policy,
                        "start_x": 500.0 + 250.0 * math.cos(bearing),
                        "start_y": 500.0 + 250.0 * math.sin(bearing),
                        "start_heading": bearing + math.pi / 2,
                    },
                ],
            )
        )
    port = LaunchConfiguration("foxglove").perform(context)
    if port:
        nodes.append(
            Node(
                package="wildfire_bringup",
                executable="live_view",
                name="live_view",
                parameters=[{"port": int(port), "n_aircraft": n}],
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
                "foxglove",
                default_value="",
                description="serve the run to Foxglove on this 127.0.0.1 port (empty: not)",
            ),
            OpaqueFunction(function=_nodes),
        ]
    )
