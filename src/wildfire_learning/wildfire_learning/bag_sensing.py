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
from wildfire_ros.bag import SENSOR_KEY, read_custom_data


def recorded_sensing(bag: Path) -> tuple[str, float]:
    """The sensor and pixel error a bag was recorded with (the paper's disc if unsaid)."""
    disc = sensors.sensing_text("disc", 0.0)
    try:  # bags from before the key, or repaired after a crash: the paper's disc
        text = read_custom_data(bag).get(SENSOR_KEY, disc)
    except OSError:
        text = disc
    try:
        return sensors.parse_sensing(text)
    except ValueError:
        raise LearningError(
            f"bag {bag}: {SENSOR_KEY} {text!r}: expected <disc|camera>,<pixel error>"
        ) from None


class NoisySensing(NamedTuple):
    """The reports and filtered belief of a noisy recording, drawn again decision by decision."""

    aircraft: list[AircraftSensor]
    team: FilteredAggregator

    @classmethod
    def of(
        cls,
        sensing: tuple[str, float],
        episode: tuple[int, str] | None,
        first_decision: int,
        n: int,
        approach: str,
        preburn_steps: int,
    ) -> NoisySensing | None:
        """None for the paper's disc; refuses what cannot be rebuilt."""
        sensor, pixel_error = sensing
        if not sensors.noisy(sensor, pixel_error):
            return None
        if approach != Approach.BELIEF:
            raise LearningError(
                f"bag: recorded with --sensor {sensor}: the observation approach's noisy "
                "images are not built yet (rebuild it for the belief approach)"
            )
        if first_decision != 0 or episode is None:
            raise LearningError(
                "bag: noisy reports are drawn again from the start: the bag needs the start "
                "pose and /wildfire/episode"
            )
        seed, shape = episode
        return cls(
            [AircraftSensor(sensor, pixel_error, seed, k) for k in range(n)],
            FilteredAggregator(seed, shape, pixel_error, preburn_steps),
        )

    def sense(self, pose: AircraftState, burning: np.ndarray) -> int:
        """One decision's reports of every aircraft at ``pose`` (fields (1, N)), fused."""
        windows: list[VisitWindow] = []
        for k, sensor in enumerate(self.aircraft):
            own = AircraftState(*(field[0, k : k + 1] for field in pose))
            windows += sensor.report(own, burning)
        return self.team.merge(windows, burning)


__all__ = ["NoisySensing", "recorded_sensing"]
