"""The world's settings: what an :class:`EnvConfig` holds, and what an episode seed draws.

One frozen value configures :class:`~wildfire_world.env.WildfireVecEnv`, the evaluation, the
training and the ROS 2 system alike (the nodes take its fields as parameters), so a
setting means the same everywhere. :func:`draw_scenario` is the one rule for what a seed
fixes besides the fire's own random numbers: shape, wind and start poses.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from wildfire_agent import dynamics
from wildfire_agent.approaches import APPROACHES, Approach, sees_cameras
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.rewards import ObservationRewardWeights
from wildfire_belief import sensors
from wildfire_belief.radio import IDEAL, CommModel
from wildfire_sim.episode import EPISODE_DEFAULTS, decisions_in
from wildfire_sim.grid import PAPER_MAP, MapGeometry
from wildfire_sim.landscape import Landscape
from wildfire_sim.seeding import Stream, generator
from wildfire_sim.shapes import Shape, ShapeMasks, start_centres_m
from wildfire_sim.spread import FireParams
from wildfire_world.errors import WorldError

OBSERVATION_KINDS = (*APPROACHES, "none")
REWARD_KINDS = APPROACHES


@dataclass(frozen=True)
class EnvConfig:
    """Scenario, observation and reward settings of the environment."""

    n_aircraft: int = 2
    """Aircraft per episode."""
    geometry: MapGeometry = PAPER_MAP
    """The map: rows and columns of 10 m cells (``--map-size``; the paper's 100 x 100)."""
    landscape: Landscape | None = None
    """Fuel raster and starting fire on ``geometry`` (``--fuel-map``, ``--ignition-map``,
    ``--ignitions``); None: the paper's homogeneous fuel and the named shapes."""
    observation: str = "obs"
    """``obs`` (sensor image), ``belief`` (ego belief image) or ``none``."""
    reward: str = "obs"
    """``obs`` (observation-based reward) or ``belief`` (team reward - proximity)."""
    shapes: tuple[str, ...] = (EPISODE_DEFAULTS.shape,)
    """Fire shapes drawn uniformly per episode."""
    wind: tuple[float, float] | None = None
    """Fixed wind (wx, wy); None draws it per episode."""
    max_wind: float = EPISODE_DEFAULTS.max_wind
    """Bound of each random wind component."""
    preburn_steps: int = EPISODE_DEFAULTS.preburn_steps
    """Fire steps before the aircraft start."""
    preburn_area_m2: float = 0.0
    """With > 0, pre-burn until the fire has touched this area instead (``--preburn-area``)."""
    max_duration_s: float = EPISODE_DEFAULTS.duration_s
    """Truncation time of the flight."""
    border_cells: int = EPISODE_DEFAULTS.border_cells
    """The episode ends when fire comes this close to the map edge."""
    start_range_m: tuple[float, float] = (150.0, 300.0)
    """Start distance from the seed centre."""
    obs_weights: ObservationRewardWeights = field(default_factory=ObservationRewardWeights)
    """Weights of the observation-based reward."""
    belief_proximity_weight: float = 0.5
    """lambda_p of the belief reward's proximity penalty."""
    fire: FireParams = field(default_factory=FireParams)
    """Fire-model parameters."""
    comm: CommModel = IDEAL
    """Radio links between the aircraft (``ideal``: one shared belief)."""
    sensor: str = "disc"
    """``disc`` (the paper's: every cell within 100 m) or ``camera`` (four cameras)."""
    pixel_error: float = 0.0
    """Probability that a report flips (``--pixel-error``; 0.1 is the camera's default)."""
    wind_filter: bool = False
    """Under noisy sensing, estimate the wind with a particle filter for the belief's
    process term (``--wind-filter``)."""

    @property
    def noisy(self) -> bool:
        """Sensing other than the paper's perfect disc: a filtered (probability) belief."""
        return sensors.noisy(self.sensor, self.pixel_error)

    def validate(self) -> EnvConfig:
        """Return self, or raise :class:`WorldError` naming the bad field."""
        if self.n_aircraft < 1:
            raise WorldError(f"aircraft: expected >= 1, got {self.n_aircraft}")
        if self.observation not in OBSERVATION_KINDS:
            raise WorldError(
                f"observation: expected one of {OBSERVATION_KINDS}, got {self.observation!r}"
            )
        if self.reward not in REWARD_KINDS:
            raise WorldError(f"reward: expected one of {REWARD_KINDS}, got {self.reward!r}")
        if not self.shapes:
            raise WorldError("shapes: expected at least one fire shape")
        for name in self.shapes:
            Shape.parse(name)
        if not 0.0 <= self.max_wind <= 1.0:
            raise WorldError(f"max_wind: expected a number in [0, 1], got {self.max_wind}")
        if self.max_duration_s <= 0:
            raise WorldError(f"duration: expected > 0 s, got {self.max_duration_s}")
        if self.preburn_steps < 0:
            raise WorldError(f"preburn_steps: expected >= 0, got {self.preburn_steps}")
        if not self.preburn_area_m2 >= 0:
            raise WorldError(f"preburn area: expected >= 0 m2, got {self.preburn_area_m2}")
        if self.preburn_area_m2 > 0 and self.noisy:
            # The filtered belief predicts the pre-burn from the episode's rules; a pre-burn
            # to an area lasts as long as the draws make it.
            raise WorldError(
                "--preburn-area: not with noisy sensing yet (its belief predicts a fixed pre-burn)"
            )
        if self.landscape is not None and self.landscape.geometry != self.geometry:
            raise WorldError(
                f"landscape: {self.landscape.geometry.text} cells on a {self.geometry.text} map"
            )
        if self.sensor not in sensors.SENSORS:
            raise WorldError(f"sensor: expected one of {sensors.SENSORS}, got {self.sensor!r}")
        if not 0.0 <= self.pixel_error < 0.5:
            raise WorldError(f"pixel error: expected a number in [0, 0.5), got {self.pixel_error}")
        if self.wind_filter and not self.pixel_error > 0.0:
            raise WorldError("wind filter: expected noisy reports (a pixel error > 0)")
        if self.wind_filter and not self.comm.ideal:
            raise WorldError(
                "wind filter: under limited radio links no aircraft holds the team's reports "
                "it reads; fly it with --comm ideal"
            )
        if self.noisy and self.sensor != "camera" and self.observation == Approach.OBS:
            raise WorldError(
                "sensor: the observation approach sees the true fire under the disc; with a "
                "pixel error it needs --sensor camera (its own camera images)"
            )
        self.fire.validate()
        return self

    @property
    def ground(self) -> Landscape:
        """The landscape the fires start on (the paper's fuel on ``geometry`` by default)."""
        return self.landscape or Landscape(self.geometry)

    @property
    def camera_view(self) -> bool:
        """The observation approach sees its camera images and is rewarded from its reports
        (``wildfire_agent.camera_view``) instead of the true fire. (Evaluation of other
        policies leaves ``reward`` at its default, unused: it does not turn this on.)"""
        return sees_cameras(self.observation, self.sensor)

    @property
    def max_decisions(self) -> int:
        return decisions_in(self.max_duration_s)


class Scenario(NamedTuple):
    """What an episode seed fixes besides the fire's own random numbers."""

    shape: Shape
    wind: np.ndarray
    start: AircraftState
    masks: ShapeMasks
    """Cells burning at ignition and cells that may hold fuel (the landscape's start)."""


def draw_scenario(seed: int, config: EnvConfig) -> Scenario:
    """Shape, wind and start poses of episode ``seed`` (its SCENARIO stream, in that order)."""
    rng = generator(seed, Stream.SCENARIO)
    shape = Shape.parse(config.shapes[int(rng.integers(len(config.shapes)))])
    drawn_wind = rng.uniform(-config.max_wind, config.max_wind, size=2)
    wind = np.asarray(config.wind, dtype=np.float64) if config.wind is not None else drawn_wind
    masks = config.ground.start(shape, seed, config.border_cells)
    centres = start_centres_m(masks.ignition, config.n_aircraft)
    low, high = config.start_range_m
    start = dynamics.start_poses(rng, config.n_aircraft, centres, low, high)
    return Scenario(shape=shape, wind=wind, start=start, masks=masks)


__all__ = [
    "OBSERVATION_KINDS",
    "REWARD_KINDS",
    "EnvConfig",
    "Scenario",
    "draw_scenario",
]
