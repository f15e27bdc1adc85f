"""What a run's ``ros__parameters`` file says to each node, beside what the launcher passes it.

ROS applies a node's ``-p`` values after its parameter files (rcl does, and so does our DDS
layer), so a value the launcher passes on a node's command line beats the file's without a
word. ``wildfire run`` therefore reads the file first and makes its values the run's own, and
then checks with :func:`compare` that every value the launcher passes agrees with the file:
each node flies what the file says, and the run's summary shows it.

Node keys match as rcl matches them (``/**``, ``/**/agent``, ``/uav0/agent``; a key without a
leading ``/`` is absolute), through the DDS layer's own parser of parameter files.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from wildfire_ros.dds.arguments import load_params_file, node_pattern_matches, parse_ros_arguments

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping, Sequence
    from pathlib import Path


@dataclass(frozen=True)
class FileValue:
    """One parameter a node gets from the file, and what the launcher passes it (if it does)."""

    node: str
    """The fully qualified node name (``/fire_simulator``, ``/uav0/agent``)."""
    name: str
    file_value: Any
    run_value: Any = None
    passed: bool = False
    """The launcher passes this parameter to this node with ``-p`` (``run_value``)."""

    @property
    def agrees(self) -> bool:
        """The launcher passes nothing, or the very value of the file."""
        return not self.passed or same_value(self.file_value, self.run_value)


def node_name(launcher_name: str) -> str:
    """The fully qualified name of a launcher's node: agent ``uavK`` is ``/uavK/agent`` (its
    namespace), every other node is its name at the root."""
    if launcher_name.startswith("uav"):
        return f"/{launcher_name}/agent"
    return f"/{launcher_name}"


def run_nodes(n_aircraft: int, live_view: bool) -> list[str]:
    """The launcher's names of the nodes a run starts (the keys of ``node_commands``)."""
    names = ["fire_simulator", "belief_aggregator", *(f"uav{k}" for k in range(n_aircraft))]
    return [*names, "live_view"] if live_view else names


def same_value(a: Any, b: Any) -> bool:
    """Equal as ROS parameters: 3 and 3.0 alike, but a bool is no number."""
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    return bool(a == b)


def file_values(path: Path, nodes: Iterable[str]) -> dict[str, dict[str, Any]]:
    """By launcher name, the parameters the file gives each node (later entries win)."""
    overrides = load_params_file(path)
    result: dict[str, dict[str, Any]] = {}
    for node in nodes:
        fqn = node_name(node)
        values = {
            o.name: o.value
            for o in overrides
            if o.node_pattern is None or node_pattern_matches(o.node_pattern, fqn)
        }
        if values:
            result[node] = values
    return result


def passed_values(command: Sequence[str]) -> dict[str, Any]:
    """The ``-p`` values of a node's command line, parsed as the node parses them."""
    words = list(command)
    # The file's own entries are what we compare against: leave them out here.
    while "--params-file" in words:
        at = words.index("--params-file")
        del words[at : at + 2]
    arguments = parse_ros_arguments(words)
    return {o.name: o.value for o in arguments.overrides}


def compare(path: Path, commands: Mapping[str, Sequence[str]]) -> list[FileValue]:
    """Every parameter the file gives a node of ``commands`` (``node_commands``' result),
    with the value its command line passes."""
    given = file_values(path, commands)
    result = []
    for node, values in given.items():
        passed = passed_values(commands[node])
        for name, value in values.items():
            result.append(FileValue(node_name(node), name, value, passed.get(name), name in passed))
    return result


__all__ = [
    "FileValue",
    "compare",
    "file_values",
    "node_name",
    "passed_values",
    "run_nodes",
    "same_value",
]
