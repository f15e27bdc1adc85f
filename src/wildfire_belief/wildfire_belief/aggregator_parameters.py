"""The belief aggregator node's parameters, and the protocol they make (no ROS).

:data:`PARAMETERS` is the node's parameter table (defaults, ranges, descriptions);
:func:`aggregator_protocol` turns the values read from it into the
:class:`~wildfire_belief.aggregator_protocol.AggregatorProtocol`: the belief starting as the
ignition seed of the episode's seed and shape, the filtered belief under noisy sensing, and
the report windows per aircraft of its sensor. A configuration is checked, one line per
mistake, before the node opens a topic.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from wildfire_belief.aggregator_protocol import AggregatorProtocol
from wildfire_belief.filtered_aggregator import FilteredAggregator
from wildfire_belief.sensors import SENSORS, check_sensing, noisy, sensors_of
from wildfire_ros.node_support import ParamSpec
from wildfire_sim.episode import EPISODE_DEFAULTS, MODES, Mode
from wildfire_sim.ground_parameters import GROUND_PARAMETERS, ground_of
from wildfire_sim.ignition import ignite
from wildfire_sim.shapes import Shape

PARAMETERS = (
    ParamSpec("n_aircraft", 2, "aircraft uav0..uav{n-1} whose visits are merged", 1, 64),
    ParamSpec(
        "seed", EPISODE_DEFAULTS.seed, "episode seed (fixes the ignition seed's fuel)", 0, 2**31 - 1
    ),
    ParamSpec(
        "shape", EPISODE_DEFAULTS.shape, "ignition shape", choices=tuple(s.value for s in Shape)
    ),
    ParamSpec("mode", "lockstep", "lockstep (sim time) or realtime", choices=MODES),
    ParamSpec(
        "recover_timeout_s", 3.0, "how long a restarted aggregator waits for a copy", 0.0, 60.0
    ),
    ParamSpec(
        "sensor",
        "disc",
        "the aircraft's sensor: disc or camera (camera0..3/cells)",
        choices=SENSORS,
    ),
    ParamSpec("pixel_error", 0.0, "probability that a report flips, below 0.5", 0.0, 0.5),
    ParamSpec(
        "wind_filter",
        False,
        "estimate the wind with a particle filter of fire models for the filtered belief's "
        "process term (needs pixel_error > 0)",
    ),
    ParamSpec(
        "preburn_steps",
        EPISODE_DEFAULTS.preburn_steps,
        "fire steps burnt before the aircraft come (the filtered belief spreads its start)",
        0,
        1000,
    ),
    ParamSpec(
        "reports",
        True,
        "acknowledge lockstep ticks (false when the agents decide on their own replicas and "
        "the fire simulator does not wait for the aggregator)",
    ),
    *GROUND_PARAMETERS,
)


def aggregator_protocol(p: Mapping[str, Any], now_ns: Callable[[], int]) -> AggregatorProtocol:
    """The protocol of the aggregator node's parameter values ``p`` (of :data:`PARAMETERS`);
    ``now_ns`` is the node clock."""
    sensor, pixel_error = p["sensor"], p["pixel_error"]
    check_sensing(sensor, pixel_error, p["wind_filter"])
    ground, border = ground_of(p), p["border_cells"]
    filtered = None
    if noisy(sensor, pixel_error):
        filtered = FilteredAggregator(
            p["seed"], p["shape"], pixel_error, p["preburn_steps"], p["wind_filter"], ground, border
        )
    return AggregatorProtocol(
        p["n_aircraft"],
        Mode(p["mode"]),
        ignite(p["seed"], p["shape"], ground, border_cells=border).burning,
        now_ns,
        p["recover_timeout_s"],
        reports=p["reports"],
        filtered=filtered,
        sources=sensors_of(sensor),
    )


__all__ = ["PARAMETERS", "aggregator_protocol"]
