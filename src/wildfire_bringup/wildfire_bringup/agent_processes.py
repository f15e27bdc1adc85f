"""Which agents share a process: composed agents (``wildfire run --agents-per-process K``).

No ROS here: the layout is names only. Every node but the agents has a process of its own;
the agents go at most ``K`` to a process (:func:`agent_groups`), and a process of several runs
``python -m wildfire_agent.agent_group`` with one ``--node`` section per agent, each the very
``--ros-args`` a lone agent process would get (:func:`composed_commands`). A process of one
agent is the lone agent's process, named ``uavK`` as ever; a process of several is named
``agentsI`` (its index among the composed ones).

Default (no ``K``): ``K = ceil(N / 8)``, so one agent per process up to 8 aircraft (the
system of one process per node) and never more than :data:`MAX_AGENT_PROCESSES` agent
processes. Either way the agents are spread evenly: ``ceil(N / K)`` processes of consecutive
aircraft, sizes differing by one at most (the larger first). On virtual hosts a process never
spans two hosts: each host's agents are split so (a host, a cut, takes whole processes).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from wildfire_ros.node_support import NODE_SECTION

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

MAX_AGENT_PROCESSES = 8
"""Agent processes of the default layout, at most."""
GROUP_MODULE = "wildfire_agent.agent_group"
"""The entry point of a process of several agents."""
GROUP_PREFIX = "agents"


def default_agents_per_process(n_aircraft: int) -> int:
    """``ceil(N / 8)``: one agent per process up to 8 aircraft, at most 8 processes above."""
    return max(1, math.ceil(n_aircraft / MAX_AGENT_PROCESSES))


def spread(members: Sequence[int], per_process: int) -> list[tuple[int, ...]]:
    """``members`` in order, in ``ceil(len / per_process)`` runs of sizes differing by one."""
    if per_process < 1:
        raise ValueError(f"agents per process: expected >= 1, got {per_process}")
    count = math.ceil(len(members) / per_process)
    groups: list[tuple[int, ...]] = []
    start = 0
    for i in range(count):
        size = len(members) // count + (1 if i < len(members) % count else 0)
        groups.append(tuple(members[start : start + size]))
        start += size
    return groups


def agent_groups(
    n_aircraft: int,
    per_process: int | None = None,
    hosts: Sequence[Sequence[str]] | None = None,
) -> list[tuple[int, ...]]:
    """The aircraft of each agent process (see the module docstring); ``hosts``: the node
    names of every virtual host (``wildfire_testbed.hosts.place_nodes``), or None."""
    k = default_agents_per_process(n_aircraft) if per_process is None else per_process
    if hosts is None:
        return spread(range(n_aircraft), k)
    groups: list[tuple[int, ...]] = []
    for names in hosts:
        agents = [int(name[3:]) for name in names if name.startswith("uav")]
        groups += spread(agents, k)
    return sorted(groups)


def process_layout(
    node_names: Sequence[str], groups: Sequence[tuple[int, ...]]
) -> dict[str, tuple[str, ...]]:
    """By process name, the nodes it carries, in the order of ``node_names`` (the launcher's
    nodes: ``fire_simulator``, ``belief_aggregator``, ``uav0`` ...)."""
    group_of = {f"uav{k}": group for group in groups for k in group}
    composed = [group for group in groups if len(group) > 1]
    layout: dict[str, tuple[str, ...]] = {}
    for name in node_names:
        group = group_of.get(name)
        if group is None or len(group) == 1:
            layout[name] = (name,)
        elif name == f"uav{group[0]}":
            layout[f"{GROUP_PREFIX}{composed.index(group)}"] = tuple(f"uav{k}" for k in group)
    return layout


def composed_commands(
    commands: Mapping[str, Sequence[str]], layout: Mapping[str, tuple[str, ...]]
) -> dict[str, list[str]]:
    """By process name, its command line: a lone node's own, or ``agent_group``'s with the
    ``--ros-args`` of every node it carries (``python -m MODULE --ros-args ...`` each)."""
    result: dict[str, list[str]] = {}
    for process, nodes in layout.items():
        if len(nodes) == 1:
            result[process] = list(commands[nodes[0]])
            continue
        python = commands[nodes[0]][0]
        sections = [[NODE_SECTION, *commands[node][3:]] for node in nodes]
        result[process] = [python, "-m", GROUP_MODULE, *(w for s in sections for w in s)]
    return result


def describe_nodes(nodes: Sequence[str], process: str) -> str:
    """``node uav1`` for a lone node, ``nodes uav0, uav1 (process agents0)`` for several."""
    if len(nodes) == 1:
        return f"node {nodes[0]}"
    return f"nodes {', '.join(nodes)} (process {process})"


__all__ = [
    "GROUP_MODULE",
    "MAX_AGENT_PROCESSES",
    "agent_groups",
    "composed_commands",
    "default_agents_per_process",
    "describe_nodes",
    "process_layout",
    "spread",
]
