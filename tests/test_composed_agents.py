"""Composed agents (``wildfire run --agents-per-process K``): which agents share a process,
the command line of a composed process, and nodes of one process that each keep their own
name, namespace and parameters on the runtime of the pass (``Node(cli_args=...)``).

The systems that fly composed agents (equal to eval, a killed process named by its nodes) are
in ``tests/test_run_system.py``."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest

from wildfire_bringup.agent_processes import (
    agent_groups,
    default_agents_per_process,
    describe_nodes,
    spread,
)
from wildfire_bringup.run_spec import node_commands, process_commands
from wildfire_cli import build_parser
from wildfire_cli.run import build_spec
from wildfire_ros.node_support import split_node_sections
from wildfire_testbed.hosts import place_nodes


def spec_of(*words: str) -> Any:
    return build_spec(build_parser("run").parse_args(["run", *words]))


def test_the_default_is_one_agent_per_process_up_to_8_and_8_processes_above() -> None:
    assert [default_agents_per_process(n) for n in (1, 8, 9, 16, 17, 32, 64)] == [
        1,
        1,
        2,
        2,
        3,
        4,
        8,
    ]
    assert agent_groups(8) == [(k,) for k in range(8)]
    assert agent_groups(9) == [(0, 1), (2, 3), (4, 5), (6, 7), (8,)]
    assert len(agent_groups(32)) == 8 and {len(g) for g in agent_groups(32)} == {4}
    for n in range(1, 65):
        groups = agent_groups(n)
        assert len(groups) <= 8 and sorted(k for g in groups for k in g) == list(range(n))


def test_k_agents_at_most_spread_evenly_and_never_across_hosts() -> None:
    assert agent_groups(3, 2) == [(0, 1), (2,)]
    assert agent_groups(10, 4) == [(0, 1, 2, 3), (4, 5, 6), (7, 8, 9)]
    assert agent_groups(3, 8) == [(0, 1, 2)]
    with pytest.raises(ValueError, match=">= 1"):
        spread([0, 1], 0)
    # Host 2 flies uav0, uav2, uav4 and host 3 uav1, uav3, uav5 (round-robin).
    assert agent_groups(6, 2, place_nodes(6, 4)) == [(0, 2), (1, 3), (4,), (5,)]
    assert agent_groups(6, 8, place_nodes(6, 2)) == [tuple(range(6))]


def test_up_to_8_aircraft_the_processes_are_todays_nodes_bit_for_bit() -> None:
    for n in (1, 3, 8):
        spec = spec_of("--aircraft", str(n))
        assert process_commands(spec) == node_commands(spec)
        assert spec.processes() == {name: (name,) for name in node_commands(spec)}


def test_a_composed_process_carries_each_nodes_own_ros_args() -> None:
    spec = spec_of("--aircraft", "3", "--agents-per-process", "2", "--foxglove", "8799")
    lone, processes = node_commands(spec), process_commands(spec)
    assert list(processes) == [
        "fire_simulator",
        "belief_aggregator",
        "agents0",
        "uav2",
        "live_view",
    ]
    command = processes["agents0"]
    assert command[:3] == [sys.executable, "-m", "wildfire_agent.agent_group"]
    own, sections = split_node_sections(command[3:])
    assert own == [] and sections == [lone["uav0"][3:], lone["uav1"][3:]]
    assert sections[0][:3] == ["--ros-args", "-r", "__ns:=/uav0"]
    assert processes["uav2"] == lone["uav2"]
    assert describe_nodes(("uav0", "uav1"), "agents0") == "nodes uav0, uav1 (process agents0)"
    assert describe_nodes(("uav2",), "uav2") == "node uav2"


# Two nodes of one process, each with its own arguments only (the process's -p reaches none).
_COMPOSED = textwrap.dedent(
    """
    import functools, sys
    from wildfire_ros import runtime
    from wildfire_ros.node_support import ParamSpec, composed_node, declare_parameters

    runtime.rclpy.init(args=["composed", "--ros-args", "-p", "rate:=9"])
    specs = [ParamSpec("rate", 1, "r", 0, 100), ParamSpec("gain", 0.5, "g", 0.0, 10.0)]
    values = []

    def build(**kwargs):
        node = runtime.Node("agent", **kwargs)
        values.append((node.get_fully_qualified_name(), declare_parameters(node, specs)))
        return node

    params = sys.argv[1]
    nodes = [
        composed_node(build, ["--ros-args", "-r", "__ns:=/uav0", "-p", "gain:=2"]),
        composed_node(build, ["--ros-args", "--params-file", params, "-r", "__ns:=/uav1"]),
    ]
    print(values)
    try:
        composed_node(build, ["--ros-args", "-r", "__ns:=/uav2", "-p", "bogus:=1"])
    except runtime.PARAMETER_ERRORS as error:
        print(error)
    runtime.rclpy.try_shutdown()
    """
)


@pytest.mark.dds
@pytest.mark.timeout(120)
def test_composed_nodes_keep_their_own_names_and_parameters(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    params = tmp_path / "p.yaml"
    params.write_text("/uav1/agent:\n  ros__parameters:\n    rate: 7\n")
    done = subprocess.run(
        [sys.executable, "-c", _COMPOSED, str(params)],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=100,
    )
    assert done.returncode == 0, done.stderr
    values, refusal = done.stdout.strip().splitlines()
    assert values == str(
        [("/uav0/agent", {"rate": 1, "gain": 2.0}), ("/uav1/agent", {"rate": 7, "gain": 0.5})]
    )
    assert "unknown parameter 'bogus' for node /uav2/agent" in refusal


@pytest.mark.dds
@pytest.mark.timeout(120)
@pytest.mark.parametrize(
    ("words", "expected"),
    [
        ([], "expected one --node --ros-args ... section per node"),
        (["--ros-args", "-p", "seed:=1"], "parameters and remappings go in a node's own section"),
        (
            ["--node", "--ros-args", "-r", "__ns:=/uav0", "--node", "--ros-args", "-r",
             "__ns:=/uav1", "-p", "aircraft:=1", "-p", "bogus:=1"],
            "unknown parameter 'bogus' for node /uav1/agent",
        ),
    ],
)  # fmt: skip
def test_agent_group_refuses_bad_input_in_one_line(
    words: list[str], expected: str, dds_env: dict[str, str]
) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "wildfire_agent.agent_group", *words],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=100,
    )
    assert done.returncode == 2
    # One line: the last (the nodes built before the bad one have said they started).
    errors = [line for line in done.stderr.splitlines() if "error" in line]
    assert errors == done.stderr.strip().splitlines()[-1:]
    assert errors[0].startswith("agent_group: error: ") and expected in errors[0]
