"""What each learning approach observes and is rewarded with — written once.

* ``obs``: the sensor image of the true fire (``sensor.py``), (1, 30, 40) per aircraft, and
  the observation-based reward r1 + r2 + r3 + r4 (``rewards.observation_rewards``); under
  camera sensing its four camera images (4, 30, 20) and the same terms from its reports
  (``camera_view``);
* ``belief``: the ego image of the shared belief and its ages (``wildfire_belief``),
  (2, 100, 100) per aircraft, and the team reward (newly seen burning cells, shared by the
  team) minus ``proximity_weight * sum_j exp(-rho_j / c)`` (:func:`belief_rewards`).

The training environment, the transitions rebuilt from bags and an agent's aircraft policy all call
these functions, so the three see and score an aircraft identically. Every array leads with
the environment dimension: poses are (E, N).
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np

from wildfire_agent import camera_view, sensor
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.rewards import ObservationRewardWeights, proximity_sum
from wildfire_belief.ego_image import IMAGE_SIZE, AgeWindow, ego_images


class Approach(StrEnum):
    """The observation kind a Q-network takes (and the reward it is trained with).

    A ``StrEnum``: its members are the strings of configs, cards and the command line.
    """

    OBS = "obs"
    BELIEF = "belief"


APPROACHES: tuple[str, ...] = tuple(Approach)
"""The approaches' names, in the order commands list them."""
IMAGE_SHAPES: dict[str, tuple[int, int, int]] = {
    Approach.OBS: (1, sensor.N_BEARINGS, sensor.N_RANGES),
    Approach.BELIEF: (2, IMAGE_SIZE, IMAGE_SIZE),
}
"""Image (C, H, W) each approach gives an aircraft: the sensor image, or the ego belief and
its ages (:func:`sensor_images`, :func:`belief_images`), under the paper's disc."""


def sees_cameras(approach: str, sensor_name: str) -> bool:
    """The one rule of the camera world's observation approach: it sees its own camera
    images and is rewarded from its reports (``camera_view``), not from the true fire."""
    return approach == Approach.OBS and sensor_name == "camera"


def image_shape(approach: str, sensor_name: str = "disc") -> tuple[int, int, int]:
    """Image (C, H, W) of ``approach`` in a world sensed by ``sensor_name``: the observation
    approach sees its camera images under ``camera`` (``camera_view.IMAGE_SHAPE``)."""
    if sees_cameras(approach, sensor_name):
        return camera_view.IMAGE_SHAPE
    return IMAGE_SHAPES[approach]


def sensor_images(truth: np.ndarray, pose: AircraftState) -> np.ndarray:
    """``obs`` images (E, N, 1, 30, 40) float32 from the (E, H, W) true fire."""
    images = sensor.observe(truth, pose.x_m, pose.y_m, pose.heading_rad)
    return images[:, :, None].astype(np.float32)


def belief_images(
    belief: np.ndarray, age_s: np.ndarray | AgeWindow, pose: AircraftState
) -> np.ndarray:
    """``belief`` images (E, N, 2, 100, 100) float32 from (E, H, W) beliefs and their ages
    (an array, or a function of the window an image reads: ``ego_image.AgeWindow``).

    ``belief`` is the team's probability of burning per cell: the believed map itself (bool)
    under the paper's perfect disc; under noisy sensing the filtered belief in the whole
    percent ``/wildfire/belief`` carries (``belief_codec.belief_probability``), so an agent's
    network sees exactly what the trained one saw.
    """
    return ego_images(belief, age_s, pose.x_m, pose.y_m, pose.heading_rad)


def belief_rewards(
    team_reward: np.ndarray,
    pose: AircraftState,
    weights: ObservationRewardWeights,
    proximity_weight: float,
) -> np.ndarray:
    """``belief`` training rewards (E, N) float64 from the (E,) team rewards of a decision."""
    proximity = proximity_sum(pose.x_m, pose.y_m, weights.proximity_scale_m)
    return np.asarray(team_reward)[:, None] - proximity_weight * proximity


__all__ = [
    "APPROACHES",
    "IMAGE_SHAPES",
    "Approach",
    "belief_images",
    "belief_rewards",
    "image_shape",
    "sees_cameras",
    "sensor_images",
]
