"""The agent node's parameters, and the protocol they make (no ROS).

:data:`PARAMETERS` is the node's parameter table (defaults, ranges, descriptions: what
``ros2 param describe`` shows and ``config/*.yaml`` sets); :func:`agent_protocol` turns the
values read from it into the aircraft's :class:`~wildfire_agent.agent_protocol.AgentProtocol`:
its start pose, its policy (``policy_names``), its radio (limited links) and its sensor. So
a configuration is checked, one line per mistake, before the node opens a topic.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from wildfire_agent.agent_protocol import AgentProtocol
from wildfire_agent.aircraft_policy import AircraftPolicy
from wildfire_agent.aircraft_radio import AircraftLinks, AircraftRadio
from wildfire_agent.aircraft_report_radio import AircraftReportRadio
from wildfire_agent.aircraft_sensor import AircraftSensor
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.policy_names import EXPECTED_POLICIES, has_network_file
from wildfire_agent.receding_horizon import RecedingHorizonConfig
from wildfire_belief.radio import CommError, CommModel
from wildfire_belief.sensors import SENSORS
from wildfire_msgs_py.contract import AIRCRAFT_PREFIX
from wildfire_ros.node_support import ParamSpec
from wildfire_sim.episode import EPISODE_DEFAULTS, MODES, Mode
from wildfire_sim.ground_parameters import GROUND_PARAMETERS, ground_of
from wildfire_sim.ignition import ignite
from wildfire_sim.shapes import Shape

PARAMETERS = (
    ParamSpec("aircraft", 0, "index k of this aircraft (namespace /uavK)", 0, 63),
    ParamSpec("n_aircraft", 2, "aircraft in the team", 1, 64),
    ParamSpec("policy", "rh", EXPECTED_POLICIES),
    ParamSpec(
        "seed", EPISODE_DEFAULTS.seed, "episode seed (the aircraft's random stream)", 0, 2**31 - 1
    ),
    ParamSpec("start_x", 500.0, "start position east, m", -10_000.0, 30_000.0),
    ParamSpec("start_y", 500.0, "start position north, m", -10_000.0, 30_000.0),
    ParamSpec("start_heading", 0.0, "start heading, rad counter-clockwise from east", -7.0, 7.0),
    ParamSpec("start_bank_steps", 0, "start bank in 5 degree steps", -10, 10),
    ParamSpec("mode", "lockstep", "lockstep (sim time) or realtime", choices=MODES),
    ParamSpec("rh_horizon", 60, "receding horizon: decisions planned ahead", 2, 400),
    ParamSpec("rh_replan_every", 10, "receding horizon: decisions flown per plan", 1, 399),
    ParamSpec("rh_restarts", 4, "receding horizon: random restarts per plan", 1, 64),
    ParamSpec("torch_threads", 1, "CPU threads of the Q-network", 1, 64),
    ParamSpec(
        "comm",
        "ideal",
        "radio links: ideal (decide on the aggregator's shared belief), none or "
        "range=R[,loss=P][,delay=D] (decide on the own replica; lockstep)",
    ),
    ParamSpec(
        "sensor",
        "disc",
        "disc (every cell within 100 m, perfectly) or camera (four cameras; reports on "
        "camera0..3/cells)",
        choices=SENSORS,
    ),
    ParamSpec(
        "pixel_error",
        0.0,
        "probability that a report flips, below 0.5 (drawn from the aircraft's stream)",
        0.0,
        0.5,
    ),
    ParamSpec(
        "preburn_steps",
        EPISODE_DEFAULTS.preburn_steps,
        "fire steps burnt before the aircraft come (the filtered replica spreads its start: "
        "noisy sensing under limited links)",
        0,
        1000,
    ),
    ParamSpec(
        "shape",
        EPISODE_DEFAULTS.shape,
        "ignition shape (the replica's start under limited links)",
        choices=tuple(s.value for s in Shape),
    ),
    *GROUND_PARAMETERS,
)


def agent_protocol(p: Mapping[str, Any], now_ns: Callable[[], int]) -> AgentProtocol:
    """The protocol of the agent node's parameter values ``p`` (of :data:`PARAMETERS`);
    ``now_ns`` is the node clock. A Q-network's CPU threads are set here, before it loads."""
    k, n = p["aircraft"], p["n_aircraft"]
    if k >= n:
        raise AgentConfigError(f"aircraft {k}: expected 0..{n - 1} (n_aircraft)")
    if has_network_file(p["policy"]):  # a Q-network (obs, belief or a .pt file)
        import torch

        torch.set_num_threads(p["torch_threads"])
    planner = RecedingHorizonConfig(p["rh_horizon"], p["rh_replan_every"], p["rh_restarts"])
    start = AircraftState(
        x_m=np.array([p["start_x"]]),
        y_m=np.array([p["start_y"]]),
        heading_rad=np.array([p["start_heading"]]),
        bank_steps=np.array([p["start_bank_steps"]], dtype=np.int64),
    )
    policy = AircraftPolicy(p["policy"], k, n, p["seed"], planner, sensor=p["sensor"])
    try:
        comm = CommModel.parse(p["comm"])
    except CommError as error:
        raise AgentConfigError(str(error)) from None
    sensor = AircraftSensor(p["sensor"], p["pixel_error"], p["seed"], k)
    radio: AircraftLinks[Any] | None = None
    if not comm.ideal:
        ground, seed, border = ground_of(p), p["seed"], p["border_cells"]
        ignition = ignite(seed, p["shape"], ground, border_cells=border).burning
        if not sensor.noisy:
            radio = AircraftRadio(comm, k, n, seed, ignition)
        else:  # its own filtered replica, started as the aggregator's
            fuel = ground.start(Shape.parse(p["shape"]), seed, border).fuel
            radio = AircraftReportRadio(
                comm,
                k,
                n,
                seed,
                sensor.sensor,
                sensor.pixel_error,
                ignition,
                fuel,
                p["preburn_steps"],
            )
    name_tag = f"{AIRCRAFT_PREFIX}{k}"
    return AgentProtocol(
        k, n, Mode(p["mode"]), policy, start, name_tag, now_ns, radio=radio, sensor=sensor
    )


__all__ = ["PARAMETERS", "agent_protocol"]
