"""``wildfire run --params-file``: the file's values win over defaults the user did not type
(and reach every node's command line), a typed flag that the file contradicts is one line and
exit 2, and a run with the file's ``shape: t`` flies the T fire, as ``evaluate`` flies it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from wildfire_bringup.launcher import node_commands
from wildfire_bringup.params_file import compare, node_name, passed_values, run_nodes
from wildfire_cli import build_parser
from wildfire_cli.common import UserError
from wildfire_cli.run import add_parser, build_spec
from wildfire_cli.run_params import typed_options, with_params_file
from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig

WILDFIRE = [str(Path(sys.executable).parent / "wildfire")]
SHIPPED = Path(__file__).parents[1] / "src/wildfire_bringup/config/wildfire.yaml"


def params_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "params.yaml"
    path.write_text(text)
    return path


def spec_of(*words: str) -> tuple[Any, dict[str, Any]]:
    """The run's spec and what it took from the file, as ``wildfire run WORDS`` builds them."""
    argv = ["run", *words]
    args = build_parser("run").parse_args(argv)
    args.argv = argv
    return with_params_file(args, build_spec, add_parser)


def passed(spec: Any, node: str) -> dict[str, Any]:
    return passed_values(node_commands(spec)[node])


def test_the_files_shape_wins_over_the_default_on_every_node(tmp_path: Path) -> None:
    path = params_file(tmp_path, "fire_simulator:\n  ros__parameters:\n    shape: t\n")
    spec, taken = spec_of("--params-file", str(path))
    assert spec.shape == "t" and taken == {"shape": "t"}
    assert passed(spec, "fire_simulator")["shape"] == "t"
    assert passed(spec, "belief_aggregator")["shape"] == "t"
    assert all(entry.agrees for entry in compare(path, node_commands(spec)))


def test_options_wind_and_start_poses_from_the_file(tmp_path: Path) -> None:
    path = params_file(
        tmp_path,
        "/**:\n  ros__parameters:\n    seed: 7\n    n_aircraft: 3\n    mode: realtime\n"
        "/fire_simulator:\n  ros__parameters:\n    wind_x: 0.25\n    duration_s: 12\n"
        "/uav2/agent:\n  ros__parameters:\n    start_x: 321.5\n    policy: random\n",
    )
    spec, taken = spec_of("--params-file", str(path))
    assert (spec.seed, spec.n_aircraft, spec.mode, spec.duration_s) == (7, 3, "realtime", 12.0)
    assert spec.policy == "random" and spec.wind[0] == 0.25 and spec.start[2, 0] == 321.5
    assert taken["seed"] == 7 and taken["/fire_simulator wind_x"] == 0.25
    assert passed(spec, "fire_simulator")["wind_x"] == 0.25
    assert passed(spec, "uav2")["start_x"] == 321.5 and passed(spec, "uav2")["policy"] == "random"
    # The wind's other component and the other aircraft keep the seed's draws.
    drawn, _ = spec_of("--seed", "7", "--aircraft", "3")
    assert spec.wind[1] == drawn.wind[1] and (spec.start[:2] == drawn.start[:2]).all()


def test_the_shipped_file_agrees_with_a_default_run() -> None:
    spec, taken = spec_of("--params-file", str(SHIPPED))
    assert spec.shape == "circular" and spec.seed == 0 and spec.policy == "rh"
    assert set(taken) <= {"/fire_simulator wind_x", "/fire_simulator wind_y", "duration_s"}
    assert all(entry.agrees or entry.name == "policy" for entry in compare(SHIPPED, {}))


@pytest.mark.parametrize(
    ("text", "words", "expected"),
    [
        (
            "fire_simulator:\n  ros__parameters:\n    shape: t\n",
            ["--shape", "circular"],
            "/fire_simulator shape is 't', but --shape circular was typed",
        ),
        (
            "/**:\n  ros__parameters:\n    mode: lockstep\n",
            ["--realtime"],
            "mode is 'lockstep', but --fast/--realtime True was typed",
        ),
        (
            "/fire_simulator:\n  ros__parameters:\n    wind_x: 0.5\n",
            ["--wind", "0.1,0.1"],
            "wind_x is 0.5, but --wind 0.1,0.1 was typed",
        ),
        (
            "/fire_simulator:\n  ros__parameters:\n    shape: t\n"
            "/belief_aggregator:\n  ros__parameters:\n    shape: arc\n",
            [],
            "shape is 't' for /fire_simulator and 'arc' for /belief_aggregator",
        ),
        (
            "/**/agent:\n  ros__parameters:\n    aircraft: 0\n",
            [],
            "/uav1/agent aircraft is 0, but the run sets it to 1 itself",
        ),
        ("/fire_simulator:\n  ros__parameters:\n    shape: x\n", [], "shape: unknown fire shape"),
        ("/**:\n  ros__parameters:\n    seed: -3\n", [], "/fire_simulator seed: argument --seed"),
    ],
)
def test_conflicts_are_one_line(tmp_path: Path, text: str, words: list[str], expected: str) -> None:
    path = params_file(tmp_path, text)
    with pytest.raises(UserError, match="--params-file") as error:
        spec_of("--params-file", str(path), *words)
    assert expected in str(error.value) and "\n" not in str(error.value)


def test_typed_options_are_what_was_typed() -> None:
    assert typed_options(["run", "--shape", "circular", "--fast"], add_parser) == {
        "shape",
        "realtime",
    }
    assert typed_options(["run", "--wind", "0,0", "--seed", "0"], add_parser) == {"wind", "seed"}
    assert typed_options(["run"], add_parser) == set()


def test_node_names_are_the_launchers() -> None:
    spec, _ = spec_of("--aircraft", "3")
    assert list(node_commands(spec)) == run_nodes(3, live_view=False)
    assert node_name("uav2") == "/uav2/agent" and node_name("fire_simulator") == "/fire_simulator"


@pytest.mark.dds
@pytest.mark.timeout(180)
def test_a_files_t_shape_flies_the_t_fire(tmp_path: Path, dds_env: dict[str, str]) -> None:
    path = params_file(tmp_path, "fire_simulator:\n  ros__parameters:\n    shape: t\n")
    words = ["--seed", "5", "--duration", "10", "--wind", "0.3,-0.2", "--fast", "--json"]
    result = subprocess.run(
        [*WILDFIRE, "run", "--params-file", str(path), *words],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=150,
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["shape"] == "t" and summary["from_params_file"] == {"shape": "t"}
    config = EnvConfig(n_aircraft=2, shapes=("t",), wind=(0.3, -0.2), max_duration_s=10.0)
    flown = evaluate(make_vec_policy("rh"), config, [5]).episodes[0]
    assert (summary["score"], summary["decisions"]) == (flown.score, flown.decisions)
    assert summary["score_ceiling"] == flown.score_ceiling
    circular = evaluate(make_vec_policy("rh"), EnvConfig(n_aircraft=2, wind=(0.3, -0.2),
                        max_duration_s=10.0), [5]).episodes[0]  # fmt: skip
    assert circular.score_ceiling != flown.score_ceiling  # the two fires differ: a real check
    typed = subprocess.run(
        [*WILDFIRE, "run", "--params-file", str(path), "--shape", "arc", "--duration", "5"],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert typed.returncode == 2 and len(typed.stderr.strip().splitlines()) == 1, typed.stderr
    assert "but --shape arc was typed" in typed.stderr
