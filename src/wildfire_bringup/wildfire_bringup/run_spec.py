"""What ``wildfire run`` starts (:class:`RunSpec`) and the command line of every node and
process (:func:`node_commands`, :func:`process_commands`). No ROS here: names and words only.

:func:`node_commands` gives each node the command line of a process of its own, by node name
(``fire_simulator``, ``belief_aggregator``, ``uavK``, ``live_view``): what a parameter file is
checked against (:mod:`wildfire_bringup.params_file`). :func:`process_commands` gives what
the launcher starts, by process name: the same, except that composed agents share a process
(:mod:`wildfire_bringup.agent_processes`).
"""

from __future__ import annotations

import sys
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from wildfire_belief.sensors import noisy
from wildfire_bringup.agent_processes import agent_groups, composed_commands, process_layout
from wildfire_bringup.monitor_protocol import REPORTER
from wildfire_sim.defaults import EPISODE_DEFAULTS
from wildfire_sim.ground_file import FILE_NAME as GROUND_FILE
from wildfire_sim.ground_file import write_ground
from wildfire_sim.ground_parameters import ground_values, wired_ground
from wildfire_sim.landscape import PAPER_LANDSCAPE, Landscape
from wildfire_testbed.hosts import place_nodes
from wildfire_testbed.netfaults import NetemSpec, Partition

LIVE_VIEW = "live_view"
"""The Foxglove live view's node: an observer the run never waits for."""


@dataclass
class RunSpec:
    """What ``wildfire run`` starts."""

    n_aircraft: int
    policy: str
    """``rh``, ``random`` or a TorchScript file path."""
    shape: str
    wind: tuple[float, float]
    seed: int
    duration_s: float
    start: np.ndarray
    """(N, 3) start x, y, heading of every aircraft."""
    lockstep: bool = True
    record_dir: Path | None = None
    respawn: bool = False
    log_dir: Path | None = None
    params_file: Path | None = None
    """A ``ros__parameters`` file given to every node (before the launcher's own values)."""
    extra_env: dict[str, str] = field(default_factory=dict)
    agent_backend: str | None = None
    """Runtime backend of the agent nodes (``rclpy``/``dds``) when it differs from the rest:
    a mixed system, the two backends talking over the wire."""
    hosts: int = 0
    """Virtual hosts (network namespaces) to spread the nodes over; 0: this machine's network."""
    netem: NetemSpec | None = None
    """Delay and loss on every host's link (with ``hosts``)."""
    partitions: tuple[Partition, ...] = ()
    """Hosts to cut off and heal during the flight (with ``hosts``)."""
    comm: str = "ideal"
    """Radio links between the aircraft (``wildfire_belief.radio``); under limited links the
    agents decide on their own replicas and the aggregator is a ground station only."""

    sensor: str = "disc"
    """The aircraft's sensor (``disc`` or ``camera``)."""
    pixel_error: float = 0.0
    """Probability that a report flips; with the camera or any error, a filtered belief."""
    wind_filter: bool = False
    """The filtered belief's process term takes a particle filter's wind estimate."""
    foxglove_port: int | None = None
    """Serve the run to Foxglove on this 127.0.0.1 port (the ``live_view`` node); None: not."""
    agents_per_process: int | None = None
    """Agent nodes per process, at most (composed agents); None: one per process up to 8
    aircraft, at most 8 agent processes above (:mod:`wildfire_bringup.agent_processes`)."""
    ground: Landscape = PAPER_LANDSCAPE
    """The map and the starting fire (``--map-size``, ``--ignitions``, the rasters): every
    node's ground parameters (:mod:`wildfire_sim.ground_parameters`)."""
    ground_file: tuple[Path, str] | None = None
    """The ground file holding ``ground``'s rasters and its SHA-256 (the launcher writes it,
    :mod:`wildfire_sim.ground_file`); None without rasters."""
    preburn_area_m2: float = 0.0
    """With > 0, the fire pre-burns until it has touched this area (``--preburn-area``)."""

    @property
    def noisy(self) -> bool:
        return noisy(self.sensor, self.pixel_error)

    @property
    def limited_links(self) -> bool:
        return self.comm != "ideal"

    @property
    def mode(self) -> str:
        return "lockstep" if self.lockstep else "realtime"

    def processes(self) -> dict[str, tuple[str, ...]]:
        """By process name (``uavK`` or ``agentsI``, the other nodes' own), its nodes."""
        hosts = place_nodes(self.n_aircraft, self.hosts) if self.hosts else None
        groups = agent_groups(self.n_aircraft, self.agents_per_process, hosts)
        names = [
            "fire_simulator",
            "belief_aggregator",
            *(f"uav{k}" for k in range(self.n_aircraft)),
        ]
        return process_layout(
            [*names, *([LIVE_VIEW] if self.foxglove_port is not None else [])], groups
        )


def with_ground_file(spec: RunSpec) -> RunSpec:
    """``spec`` with its rasters (fuel, ignition) written to a ground file in its log folder,
    made if it has none: the user's rasters are read once, by the command, and every node
    reads the resolved arrays (:mod:`wildfire_sim.ground_file`). Without rasters: ``spec``."""
    if not spec.ground.has_rasters or spec.ground_file is not None:
        return spec
    log_dir = spec.log_dir or Path(tempfile.mkdtemp(prefix="wildfire-run-"))
    log_dir.mkdir(parents=True, exist_ok=True)
    path = (log_dir / GROUND_FILE).resolve()
    return replace(spec, log_dir=log_dir, ground_file=(path, write_ground(spec.ground, path)))


def _reads_as_number(text: str) -> bool:
    """Whether a YAML reader (PyYAML, or rcl's stricter-typed one) may take ``text`` as no
    string: a number (``1e5`` included), a boolean or null."""
    return not isinstance(yaml.safe_load(text or "''"), str) or (
        bool(text) and set(text) <= set("0123456789.eE+-")
    )


def _param_args(params: dict[str, Any]) -> list[str]:
    args: list[str] = []
    for name, value in params.items():
        if isinstance(value, float):
            text = repr(value)
        elif isinstance(value, bool):
            text = str(value).lower()
        elif isinstance(value, str) and _reads_as_number(value):
            # ROS reads a -p value as YAML: a digest of digits would arrive as a number.
            text = repr(value)
        else:
            text = str(value)
        args += ["-p", f"{name}:={text}"]
    return args


def node_commands(
    spec: RunSpec, agent_states: dict[int, np.ndarray] | None = None
) -> dict[str, list[str]]:
    """Command line of every node, by node name (``fire_simulator``, ``uav0``, ...)."""
    ground = ground_values(spec.ground, EPISODE_DEFAULTS.border_cells, spec.ground_file)
    # Only the fire simulator reads the ground file; the others wait for it on the wire.
    common = {"seed": spec.seed, "shape": spec.shape, "mode": spec.mode, **wired_ground(ground)}
    sensing = {"sensor": spec.sensor, "pixel_error": spec.pixel_error} if spec.noisy else {}
    commands = {
        "fire_simulator": [
            "wildfire_sim.fire_simulator_node",
            *_param_args(
                {
                    **common,
                    **ground,
                    "wind_x": float(spec.wind[0]),
                    "wind_y": float(spec.wind[1]),
                    "duration_s": float(spec.duration_s),
                    "n_aircraft": spec.n_aircraft,
                    "extra_reporters": REPORTER,
                    "aggregator_reports": not spec.limited_links,
                    **({"preburn_area_m2": spec.preburn_area_m2} if spec.preburn_area_m2 else {}),
                }
            ),
        ],
        "belief_aggregator": [
            "wildfire_belief.belief_aggregator_node",
            *_param_args(
                {
                    **common,
                    **sensing,
                    **({"wind_filter": True} if spec.wind_filter else {}),
                    "n_aircraft": spec.n_aircraft,
                    "reports": not spec.limited_links,
                }
            ),
        ],
    }
    for k in range(spec.n_aircraft):
        x, y, heading = (float(v) for v in spec.start[k])
        bank_steps = 0
        if agent_states and k in agent_states:
            x, y, heading, bank = (float(v) for v in agent_states[k])
            bank_steps = round(bank / np.deg2rad(5.0))
        params = {
            "seed": spec.seed,
            "mode": spec.mode,
            "aircraft": k,
            "n_aircraft": spec.n_aircraft,
            "policy": spec.policy,
            "start_x": x,
            "start_y": y,
            "start_heading": heading,
            "start_bank_steps": bank_steps,
            **wired_ground(ground),
        }
        if spec.limited_links:
            params |= {"comm": spec.comm, "shape": spec.shape}
        params |= sensing
        commands[f"uav{k}"] = [
            "wildfire_agent.agent_node",
            "--ros-args",
            "-r",
            f"__ns:=/uav{k}",
            *_param_args(params),
        ]
    if spec.foxglove_port is not None:
        # An observer: no reporter of the lockstep barrier, and the run flies on without it.
        commands[LIVE_VIEW] = [
            "wildfire_bringup.live_view_node",
            *_param_args(
                {
                    "port": spec.foxglove_port,
                    "n_aircraft": spec.n_aircraft,
                    "map_rows": spec.ground.geometry.rows,
                    "map_cols": spec.ground.geometry.cols,
                }
            ),
        ]
    for name, command in commands.items():
        module, *rest = command
        if rest[:1] == ["--ros-args"]:
            rest = rest[1:]
        if spec.params_file is not None:
            rest = ["--params-file", str(spec.params_file), *rest]
        commands[name] = [sys.executable, "-m", module, "--ros-args", *rest]
    return commands


def process_commands(
    spec: RunSpec, agent_states: dict[int, np.ndarray] | None = None
) -> dict[str, list[str]]:
    """Command line of every process, by process name (:meth:`RunSpec.processes`)."""
    return composed_commands(node_commands(spec, agent_states), spec.processes())


__all__ = ["LIVE_VIEW", "RunSpec", "node_commands", "process_commands", "with_ground_file"]
