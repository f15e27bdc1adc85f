"""Noisy sensing in a recorded bag: what it was recorded with, and its reports drawn again.

A bag of ``wildfire run --record --sensor camera`` (or a pixel error) says its sensing in
``metadata.yaml`` (``custom_data``, ``wildfire.sensor: camera,0.1``). Its transitions are
rebuilt as the system made them: each aircraft's reports are drawn again from its own seeded
stream at the recorded poses and fire maps (``wildfire_agent.aircraft_sensor``), and fused
into the filtered belief as the aggregator fused them
(``wildfire_belief.filtered_aggregator``).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from wildfire_agent.aircraft_sensor import AircraftSensor
from wildfire_agent.approaches import Approach
from wildfire_agent.dynamics import AircraftState
from wildfire_belief import sensors
from wildfire_belief.filtered_aggregator import FilteredAggregator
from wildfire_learning.errors import LearningError
from wildfire_msgs_py.codecs import VisitWindow
from wildfire_ros.bag import SENSOR_KEY, WIND_FILTER_KEY, read_custom_data


class Sensing(NamedTuple):
    """How a recorded run sensed: its sensor, pixel error and whether a wind filter drove
    the filtered belief's process term."""

    sensor: str = "disc"
    pixel_error: float = 0.0
    wind_filter: bool = False

    @property
    def noisy(self) -> bool:
        return sensors.noisy(self.sensor, self.pixel_error)


def recorded_sensing(bag: Path) -> Sensing:
    """How a bag's run sensed (the paper's disc if unsaid)."""
    try:  # bags from before the keys, or repaired after a crash: the paper's disc
        custom = read_custom_data(bag)
    except OSError:
        custom = {}
    text = custom.get(SENSOR_KEY, sensors.sensing_text("disc", 0.0))
    try:
        sensor, pixel_error = sensors.parse_sensing(text)
    except ValueError:
        raise LearningError(
            f"bag {bag}: {SENSOR_KEY} {text!r}: expected <disc|camera>,<pixel error>"
        ) from None
    return Sensing(sensor, pixel_error, custom.get(WIND_FILTER_KEY) == "true")


class NoisySensing(NamedTuple):
    """The reports and filtered belief of a noisy recording, drawn again decision by decision."""

    aircraft: list[AircraftSensor]
    team: FilteredAggregator

    @classmethod
    def of(
        cls,
        sensing: Sensing,
        episode: tuple[int, str] | None,
        first_decision: int,
        n: int,
        approach: str,
        preburn_steps: int,
    ) -> NoisySensing | None:
        """None for the paper's disc; refuses what cannot be rebuilt."""
        sensor, pixel_error, wind_filter = sensing
        if not sensing.noisy:
            return None
        if approach == Approach.OBS and sensor != "camera":
            raise LearningError(
                f"bag: recorded with --sensor {sensor} and a pixel error: the observation "
                "approach sees camera images only under --sensor camera"
            )
        if first_decision != 0 or episode is None:
            raise LearningError(
                "bag: noisy reports are drawn again from the start: the bag needs the start "
                "pose and /wildfire/episode"
            )
        seed, shape = episode
        return cls(
            [AircraftSensor(sensor, pixel_error, seed, k) for k in range(n)],
            FilteredAggregator(seed, shape, pixel_error, preburn_steps, wind_filter),
        )

    def sense(
        self, pose: AircraftState, burning: np.ndarray
    ) -> tuple[int, list[tuple[VisitWindow, ...]]]:
        """One decision's reports of every aircraft at ``pose`` (fields (1, N)), fused: the
        team reward, and each aircraft's windows (what its agent published)."""
        reports = []
        for k, sensor in enumerate(self.aircraft):
            own = AircraftState(*(field[0, k : k + 1] for field in pose))
            reports.append(sensor.report(own, burning))
        return self.team.merge([w for own in reports for w in own], burning), reports


__all__ = ["NoisySensing", "Sensing", "recorded_sensing"]
