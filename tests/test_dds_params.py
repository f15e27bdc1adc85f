"""``--ros-args`` parsing, parameter files and declared parameters."""

from __future__ import annotations

from pathlib import Path

import pytest

from wildfire_msgs_py.errors import ParameterError
from wildfire_ros.dds.arguments import (
    node_pattern_matches,
    parse_ros_arguments,
    remove_ros_args,
)


def test_p_values_are_yaml_typed() -> None:
    args = parse_ros_arguments(
        [
            "prog",
            "--ros-args",
            "-p",
            "rate:=10",
            "-p",
            "gain:=0.5",
            "-p",
            "on:=true",
            "-p",
            "name:=uav",
            "-p",
            "seeds:=[1, 2]",
            "--log-level",
            "warn",
        ]
    )
    values = {name: o.value for name, o in args.parameters_for("/agent").items()}
    assert values == {"rate": 10, "gain": 0.5, "on": True, "name": "uav", "seeds": [1, 2]}
    assert args.log_level == "warn"


def test_remove_ros_args_keeps_the_rest() -> None:
    assert remove_ros_args(["prog", "--x", "--ros-args", "-p", "a:=1", "--", "tail"]) == [
        "prog",
        "--x",
        "tail",
    ]


def test_params_file_node_keys_and_precedence(tmp_path: Path) -> None:
    params = tmp_path / "params.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    use_sim_time: true\n    rate: 1\n"
        "/uav0/agent:\n  ros__parameters:\n    policy:\n      path: p.pt\n    rate: 2\n"
        "fire_sim:\n  ros__parameters:\n    rate: 3\n"
    )
    args = parse_ros_arguments(["--ros-args", "--params-file", str(params), "-p", "agent:rate:=5"])
    agent = {n: o.value for n, o in args.parameters_for("/uav0/agent").items()}
    assert agent == {"use_sim_time": True, "rate": 5, "policy.path": "p.pt"}
    fire = {n: o.value for n, o in args.parameters_for("/fire_sim").items()}
    assert fire == {"use_sim_time": True, "rate": 3}
    other = {n: o.value for n, o in args.parameters_for("/uav1/agent").items()}
    assert other == {"use_sim_time": True, "rate": 5}


@pytest.mark.parametrize(
    ("pattern", "node", "expected"),
    [
        ("/**", "/a", True),
        ("/**", "/uav0/a", True),
        ("/**/a", "/a", True),
        ("/**/a", "/uav0/a", True),
        ("/a", "/uav0/a", False),
        ("/uav*/a", "/uav3/a", True),
        ("/uav*/a", "/x/uav3/a", False),
    ],
)
def test_node_patterns(pattern: str, node: str, expected: bool) -> None:
    assert node_pattern_matches(pattern, node) is expected


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--ros-args", "-p", "rate"], "expected NAME:=VALUE"),
        (["--ros-args", "-p"], "missing its argument"),
        (["--ros-args", "--bogus"], "unknown option '--bogus'"),
        (["--ros-args", "-p", "x:=[1, 2"], "not valid YAML"),
        (["--ros-args", "-p", "x:={a: 1}"], "not a ROS parameter type"),
        (["--ros-args", "--params-file", "/nonexistent/p.yaml"], "cannot read"),
        (["--ros-args", "--log-level", "loud"], "expected one of"),
    ],
)
def test_bad_ros_args_give_one_clear_line(argv: list[str], message: str) -> None:
    with pytest.raises(ParameterError, match=message) as info:
        parse_ros_arguments(argv)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("a: [1, 2\n", "malformed YAML"),
        ("- 1\n", "expected a mapping"),
        ("node:\n  params:\n    a: 1\n", "no 'ros__parameters'"),
    ],
)
def test_bad_params_files(tmp_path: Path, text: str, message: str) -> None:
    params = tmp_path / "bad.yaml"
    params.write_text(text)
    with pytest.raises(ParameterError, match=message) as info:
        parse_ros_arguments(["--ros-args", "--params-file", str(params)])
    assert str(params) in str(info.value)


@pytest.mark.dds
def test_node_parameters_from_ros_args(tmp_path: Path) -> None:
    from wildfire_ros.dds import init, try_shutdown
    from wildfire_ros.dds.node import Node
    from wildfire_ros.runtime import FloatingPointRange, ParameterDescriptor

    params = tmp_path / "p.yaml"
    params.write_text("/**:\n  ros__parameters:\n    speed: 18.5\n    label: from_file\n")
    init(
        args=[
            "--ros-args",
            "--params-file",
            str(params),
            "-p",
            "count:=4",
            "-p",
            "gain:=2",
            "-r",
            "__ns:=/uav3",
        ]
    )
    try:
        node = Node("agent")
        assert node.get_fully_qualified_name() == "/uav3/agent"
        assert node.declare_parameter("speed", 20.0).value == 18.5
        assert node.declare_parameter("count", 1).value == 4
        assert node.declare_parameter("gain", 1.0).value == 2.0  # int accepted for a float
        assert node.declare_parameter("label", "x").value == "from_file"
        assert node.declare_parameter("untouched", 7).value == 7
        assert node.get_parameter("use_sim_time").value is False
        with pytest.raises(ParameterError, match="already declared"):
            node.declare_parameter("speed", 1.0)
        with pytest.raises(ParameterError, match="not declared"):
            node.get_parameter("nope")
        descriptor = ParameterDescriptor(
            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=10.0, step=0.0)]
        )
        with pytest.raises(ParameterError, match="out of range"):
            node.declare_parameter("speed_2", 18.5, descriptor)
        bad = Node("bad_types")
        with pytest.raises(ParameterError, match="expected integer"):
            bad.declare_parameter("label", 3)
        from wildfire_ros.runtime import Parameter

        result = node.set_parameters([Parameter("count", value="many")])
        assert not result[0].successful and "expected integer" in result[0].reason
        assert node.set_parameters([Parameter("count", value=9)])[0].successful
        assert node.get_parameter("count").value == 9
    finally:
        try_shutdown()
