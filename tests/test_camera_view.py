"""The observation approach under cameras (wildfire_agent.camera_view): each pixel shows the
report of the cell its ray hits (checked against rays traced by hand), the images an agent
makes from its own reports are the environment's, and the rewards read the reports only."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from wildfire_agent import camera_view
from wildfire_agent.aircraft_policy import AircraftPolicy
from wildfire_agent.aircraft_sensor import AircraftSensor
from wildfire_agent.camera import camera_windows
from wildfire_agent.camera_view import BURNING, CLEAR, NOTHING, camera_images, report_codes
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError
from wildfire_agent.rewards import ObservationRewardWeights
from wildfire_learning.errors import LearningError
from wildfire_learning.replay import ImageCodec
from wildfire_world.env import EnvConfig, WildfireVecEnv
from wildfire_world.errors import WorldError

CAMERA_WORLD = EnvConfig(observation="obs", reward="obs", sensor="camera", pixel_error=0.1)
POSES = [
    (505.0, 505.0, 0.0, 0),
    (503.7, 488.2, 217.0, 4),
    (40.0, 960.0, 90.0, -10),
    (975.0, 130.0, 30.0, 10),
]


def pose_of(x: float, y: float, heading_deg: float, bank_steps: int) -> AircraftState:
    return AircraftState(
        x_m=np.array([[x]]),
        y_m=np.array([[y]]),
        heading_rad=np.array([[math.radians(heading_deg)]]),
        bank_steps=np.array([[bank_steps]]),
    )


def traced_cell(
    x: float, y: float, heading_deg: float, bank_steps: int, camera: int, row: int, col: int
) -> tuple[int, int] | None:
    """The map cell (row, col) the ray of a pixel's centre hits, traced in the world frame
    from the camera's axes as the model states them; None if it misses the ground."""
    psi, phi = math.radians(heading_deg), math.radians(5.0 * bank_steps)
    theta, roll = math.radians(30.0), math.radians((40.0, 13.0, -13.0, -40.0)[camera])
    f = np.array([math.cos(psi), math.sin(psi), 0.0])
    s = np.array([-math.sin(psi), math.cos(psi), 0.0])
    z = np.array([0.0, 0.0, 1.0])
    left, up = math.cos(phi) * s - math.sin(phi) * z, math.sin(phi) * s + math.cos(phi) * z
    ct, st, cr, sr = math.cos(theta), math.sin(theta), math.cos(roll), math.sin(roll)
    a = st * f + ct * sr * left - ct * cr * up  # the optical axis
    h = cr * left + sr * up  # image x
    v = ct * f - st * sr * left + st * cr * up  # image y
    x_mm, y_mm = 12.0 - (col + 0.5) * 1.2, 18.0 - (row + 0.5) * 1.2  # row 0 far, column 0 left
    ray = a + x_mm / 50.0 * h + y_mm / 50.0 * v
    if ray[2] >= 0:
        return None
    t = 200.0 / -ray[2]
    return math.floor((y + t * ray[1]) / 10.0), math.floor((x + t * ray[0]) / 10.0)


@pytest.mark.parametrize("pose", POSES)
def test_each_pixel_shows_the_report_of_the_cell_its_ray_hits(pose: tuple) -> None:
    state = pose_of(*pose)
    windows = camera_windows(state.x_m, state.y_m, state.heading_rad, state.bank_steps)
    rng = np.random.default_rng(1)
    codes = report_codes(windows.seen, rng.random(windows.seen.shape) < 0.5)[0, 0]
    images = camera_images(codes[None, None], windows.row0, windows.col0, state)[0, 0]
    row0, col0 = int(windows.row0[0, 0]), int(windows.col0[0, 0])
    shown = 0
    for camera, row, col in np.ndindex(*images.shape):
        cell = traced_cell(*pose, camera, row, col)
        code = NOTHING
        if cell is not None and 0 <= cell[0] - row0 < 61 and 0 <= cell[1] - col0 < 61:
            code = codes[camera, cell[0] - row0, cell[1] - col0]
        assert images[camera, row, col] == code / 2.0, (camera, row, col)
        shown += code != NOTHING
    # Most pixels of a camera that sees anything show a report (edges and range aside).
    seeing = windows.seen[0, 0].any(axis=(-2, -1))
    assert shown >= 0.5 * 600 * seeing.sum()


def test_an_agent_makes_the_environments_images_from_its_own_reports() -> None:
    seed, n = 2000003, 2
    env = WildfireVecEnv(replace(CAMERA_WORLD, n_aircraft=n), 2)
    observations = env.reset([seed + 1, seed])  # the episode under test is environment 1
    sensors = [AircraftSensor("camera", 0.1, seed, k) for k in range(n)]
    pilots = [AircraftPolicy("random", k, n, seed, sensor="camera") for k in range(n)]
    team = AircraftState(*(field[1] for field in env.aircraft))
    for k, pilot in enumerate(pilots):  # nothing reported before the first decision
        image = pilot.camera_image(AircraftState(*(f[None] for f in team)), None)
        np.testing.assert_array_equal(image, observations["image"][1, k : k + 1])
        assert not image.any()
    rng = np.random.default_rng(3)
    for _ in range(60):
        result = env.step(rng.integers(0, 2, size=(2, n)))
        team = AircraftState(*(field[1] for field in env.aircraft))
        truth = env.truth[1].astype(bool)
        for k, (sensor, pilot) in enumerate(zip(sensors, pilots, strict=True)):
            reports = sensor.report(AircraftState(*(f[k : k + 1] for f in team)), truth)
            image = pilot.camera_image(AircraftState(*(f[None] for f in team)), reports)
            np.testing.assert_array_equal(image, result.observations["image"][1, k : k + 1])
    assert set(np.unique(result.observations["image"])) <= {0.0, 0.5, 1.0}
    assert (result.observations["image"] == 1.0).any()


def test_the_rewards_read_the_reports_not_the_truth() -> None:
    weights = ObservationRewardWeights()
    state = pose_of(505.0, 505.0, 0.0, 0)
    windows = camera_windows(state.x_m, state.y_m, state.heading_rad, state.bank_steps)
    seen = windows.seen
    rng = np.random.default_rng(7)
    noise = rng.random(seen.shape) < 0.1  # one report in ten says burning, in clear country
    clear = camera_view.camera_fire_terms(
        report_codes(seen, noise), windows.row0, windows.col0, state, weights
    )
    fire = np.zeros(seen.shape, dtype=bool)
    fire[..., 27:34, 48:55] = True  # a burning block ~200 m ahead (east, the heading)
    ahead = camera_view.camera_fire_terms(
        report_codes(seen, noise ^ fire), windows.row0, windows.col0, state, weights
    )
    # Clear country: no 3 x 3 majority says fire (r1 at its cap, -1), most reports say clear.
    assert -2.0 < clear[0, 0] < -1.8
    # The block: r1 is its distance, ~200 m of 500; r2 counts its burning reports too.
    assert clear[0, 0] + 0.5 < ahead[0, 0] < -1.0
    codes = report_codes(seen, noise ^ fire)
    assert ((codes == BURNING) | (codes == CLEAR) | (codes == NOTHING)).all()


def test_the_environment_rewards_its_camera_images_world() -> None:
    env = WildfireVecEnv(CAMERA_WORLD, 3)
    env.reset([11, 12, 13])
    rng = np.random.default_rng(0)
    for _ in range(30):
        result = env.step(rng.integers(0, 2, size=(3, 2)))
    assert env.sensing is not None and env.sensing.codes is not None
    expected = camera_view.camera_rewards(
        env.sensing.codes, *env.sensing.code_origin, env.aircraft, CAMERA_WORLD.obs_weights
    )
    np.testing.assert_array_equal(result.rewards, expected)
    images = result.observations["image"]
    assert images.shape == (3, 2, *camera_view.IMAGE_SHAPE)
    codec = ImageCodec.for_approach("obs", "camera")
    import torch

    decoded = codec.decode(torch.from_numpy(codec.encode(images.reshape(-1, 4, 30, 20))))
    np.testing.assert_array_equal(decoded.numpy(), images.reshape(-1, 4, 30, 20))


def test_the_observation_approach_needs_cameras_under_noise() -> None:
    with pytest.raises(WorldError, match="--sensor camera"):
        EnvConfig(observation="obs", sensor="disc", pixel_error=0.1).validate()


def test_a_network_flies_only_the_world_of_its_images() -> None:
    with pytest.raises(AgentConfigError, match=r"takes obs images \(1, 30, 40\)"):
        AircraftPolicy("obs", 0, 2, 0, sensor="camera")


def test_a_noisy_disc_bag_gives_no_observation_transitions() -> None:
    from wildfire_learning.bag_sensing import NoisySensing, Sensing

    with pytest.raises(LearningError, match="camera images only under --sensor camera"):
        NoisySensing.of(Sensing("disc", 0.1), (5, "circular"), 0, 2, "obs", 4)
