"""The ground file: a run's fuel and ignition rasters, resolved once by the command, read by the
fire simulator and received by every other node on the wire, checked against the digest the
launcher passed, refused in one line otherwise."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from wildfire_agent.agent_parameters import PARAMETERS as AGENT_PARAMETERS
from wildfire_agent.agent_parameters import agent_protocol
from wildfire_belief.aggregator_parameters import PARAMETERS as AGGREGATOR_PARAMETERS
from wildfire_belief.aggregator_parameters import aggregator_protocol
from wildfire_msgs_py.errors import ParameterError
from wildfire_sim.fuel_map import FuelMap
from wildfire_sim.grid import MapGeometry
from wildfire_sim.ground_file import accept_ground, write_ground
from wildfire_sim.ground_parameters import (
    GROUND_PARAMETERS,
    ground_of,
    ground_values,
    wired_ground,
)
from wildfire_sim.ignition import ignite
from wildfire_sim.landscape import Landscape

GEOMETRY = MapGeometry(120, 90)


def rastered(spread: bool = True, ignition: bool = True) -> Landscape:
    rng = np.random.default_rng(4)
    low = rng.integers(0, 20, GEOMETRY.shape).astype(np.int8)
    low[:, 40:43] = 0  # a firebreak
    high = (low + 3 * (low > 0)).astype(np.int8)
    multiplier = rng.uniform(0.5, 2.0, GEOMETRY.shape).astype(np.float32) if spread else None
    fuel = FuelMap(low, high, multiplier, "cover.tif (corine)", "ab" * 32)
    burning = None
    if ignition:
        burning = np.zeros(GEOMETRY.shape, dtype=bool)
        burning[50:56, 20:26] = True
    return Landscape(GEOMETRY, fuel, burning)


def params(path: Path, sha256: str, **values: object) -> dict[str, object]:
    base = {spec.name: spec.default for spec in GROUND_PARAMETERS}
    return base | {
        "map_rows": GEOMETRY.rows,
        "map_cols": GEOMETRY.cols,
        "ground_file": str(path),
        "ground_sha256": sha256,
        **values,
    }


@pytest.mark.parametrize(("spread", "ignition"), [(True, True), (False, True), (True, False)])
def test_the_nodes_read_the_very_ground_the_command_resolved(
    tmp_path: Path, spread: bool, ignition: bool
) -> None:
    ground = rastered(spread, ignition)
    path = tmp_path / "ground.npz"
    sha = write_ground(ground, path)
    read = ground_of(params(path, sha))
    assert read.summary() == ground.summary()
    assert read.fuel is not None and ground.fuel is not None
    assert np.array_equal(read.fuel.low, ground.fuel.low)
    assert np.array_equal(read.fuel.high, ground.fuel.high)
    if spread:
        assert read.fuel.spread is not None and ground.fuel.spread is not None
        assert np.array_equal(read.fuel.spread, ground.fuel.spread)
    else:
        assert read.fuel.spread is None
    for shape in ("circular", "t"):
        # The start every node builds from it (fire, belief, replicas) is eval's.
        assert np.array_equal(
            ignite(7, shape, read, border_cells=6).burning,
            ignite(7, shape, ground, border_cells=6).burning,
        )
    values = ground_values(ground, 6, (path, sha))
    assert values["ground_file"] == str(path) and values["ground_sha256"] == sha
    with pytest.raises(ValueError, match="ground file"):
        ground_values(ground, 6)  # rasters never go out as plain parameters


def test_a_ground_file_that_is_not_the_runs_is_refused_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "ground.npz"
    sha = write_ground(rastered(), path)
    other = tmp_path / "other.npz"
    write_ground(rastered(spread=False), other)
    cases = [
        (params(other, sha), "not the file this run was launched with"),
        (params(tmp_path / "missing.npz", sha), "cannot be read"),
        (params(path, sha, map_rows=100), r"fuel_low is int8 \(120, 90\), expected int8 \(100"),
        (params(path, sha, ignitions=2), "an ignition map and ignitions=2"),
    ]
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    cases.append((params(tmp_path / "junk.npz", ""), "not a ground file"))
    for values, expected in cases:
        with pytest.raises(ParameterError, match=expected) as error:
            ground_of(values)
        assert "\n" not in str(error.value)
    # Both the agent's and the aggregator's protocols start from it.
    aggregator = {spec.name: spec.default for spec in AGGREGATOR_PARAMETERS}
    aggregator_protocol(aggregator | params(path, sha), lambda: 0)
    agent = {spec.name: spec.default for spec in AGENT_PARAMETERS} | params(path, sha)
    assert agent_protocol(agent | {"comm": "range=300"}, lambda: 0).radio is not None
    with pytest.raises(ParameterError, match="ground_sha256"):
        aggregator_protocol(aggregator | params(path, "0" * 64), lambda: 0)


def test_a_node_given_another_ground_file_exits_with_one_line(tmp_path: Path) -> None:
    path = tmp_path / "ground.npz"
    write_ground(rastered(), path)
    done = subprocess.run(
        [
            *(sys.executable, "-m", "wildfire_sim.fire_simulator_node", "--ros-args"),
            *("-p", "map_rows:=120", "-p", "map_cols:=90", "-p", f"ground_file:={path}"),
            *("-p", f"ground_sha256:={'ab' * 32}"),
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "not the file this run was launched with" in lines[0], lines


def test_the_other_nodes_fly_the_ground_received_on_the_wire(tmp_path: Path) -> None:
    """Without ground_file, a node's ground is the one received with its digest."""
    ground = rastered()
    path = tmp_path / "ground.npz"
    sha = write_ground(ground, path)
    wired = params(path, sha) | {"ground_file": ""}
    with pytest.raises(ParameterError, match="no such ground received") as error:
        ground_of(wired)
    assert "\n" not in str(error.value)
    assert not accept_ground(b"another run's ground", sha)
    assert accept_ground(path.read_bytes(), sha)
    read = ground_of(wired)
    assert read.summary() == ground.summary()
    assert np.array_equal(
        ignite(3, "circular", read, border_cells=6).burning,
        ignite(3, "circular", ground, border_cells=6).burning,
    )
    # What the launcher passes: the file to the fire simulator only.
    values = ground_values(ground, 6, (path, sha))
    assert (
        "ground_file" not in wired_ground(values) and wired_ground(values)["ground_sha256"] == sha
    )
