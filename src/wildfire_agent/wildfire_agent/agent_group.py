"""Composed agents: several agent nodes in one process, on one executor (ROS 2 composition).

``python -m wildfire_agent.agent_group --node --ros-args -r __ns:=/uav0 -p aircraft:=0 ...
--node --ros-args -r __ns:=/uav1 -p aircraft:=1 ...`` (console script ``agent_group``): each
``--node`` section is the command line a lone agent process gets (``agent_node``), and makes
one :class:`~wildfire_agent.agent_node.AgentNode` with its own name and namespace
(``/uavK/agent``), parameters, topics and deadlines
(``Node(cli_args=..., use_global_arguments=False)``). One torch, one DDS participant and one
executor serve them all: ``wildfire run --agents-per-process K`` starts these (see
``docs/deployment.md``, "Composed agents"). The process-wide ``--ros-args`` before the first
``--node`` configure logging only (:func:`wildfire_ros.node_support.run_composed`).
"""

from __future__ import annotations

import sys

from wildfire_agent.agent_node import AgentNode
from wildfire_agent.errors import AgentConfigError
from wildfire_ros.node_support import run_composed


def main(args: list[str] | None = None) -> None:
    """``ros2 run wildfire_agent agent_group --node --ros-args -r __ns:=/uav0 ... --node ...``."""
    sys.exit(run_composed(AgentNode, "agent_group", args, (AgentConfigError, ValueError)))


if __name__ == "__main__":
    main()
