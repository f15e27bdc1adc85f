"""The episode rule book (``wildfire_sim.episode``): border rule, cadence, defaults."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np
import pytest
import yaml

from wildfire_sim.episode import (
    DECISIONS_PER_FIRE_STEP,
    EPISODE_DEFAULTS,
    EpisodeDefaults,
    FireEpisode,
    decisions_in,
    fire_at_border,
    initial_fire,
)
from wildfire_sim.fire import BatchedFire, FireParams
from wildfire_sim.grid import MapGeometry
from wildfire_sim.ignition import ignite
from wildfire_sim.shapes import Shape, shape_masks
from wildfire_world.env import EnvConfig, WildfireVecEnv

REPO = Path(__file__).resolve().parents[1]
CONFIG_FILES = sorted([*REPO.glob("config/*.yaml"), *REPO.glob("src/*/config/*.yaml")])


def _loop_border(burning: np.ndarray, band: int) -> bool:
    """The rule spelt out cell by cell."""
    height, width = burning.shape
    return any(
        burning[r, c] and min(r, c, height - 1 - r, width - 1 - c) < band
        for r in range(height)
        for c in range(width)
    )


@pytest.mark.parametrize("band", [0, 1, 6, 49, 60])
def test_fire_at_border_is_batched_over_leading_dimensions(band: int) -> None:
    rng = np.random.default_rng(band)
    grids = np.zeros((5, 20, 20), dtype=bool)
    grids[1, 10, 10] = True  # centre only
    grids[2, 0, 7] = True  # top edge
    grids[3, 19 - min(band, 19), 4] = True  # on the inner side of the band
    grids[4] = rng.random((20, 20)) < 0.05
    expected = np.array([_loop_border(g, band) for g in grids])
    batched = fire_at_border(grids, band)
    assert batched.shape == (5,) and batched.dtype == bool
    np.testing.assert_array_equal(batched, expected)
    for grid, answer in zip(grids, expected, strict=True):
        one = fire_at_border(grid, band)
        assert one.shape == () and bool(one) == answer
    np.testing.assert_array_equal(
        fire_at_border(grids.reshape(5, 1, 20, 20), band), expected[:, None]
    )


def test_fire_episode_ends_with_the_environment() -> None:
    # A strong east wind drives the fire to the border, so both end rules are exercised.
    for wind, duration in (((0.8, 0.0), 400.0), ((0.0, 0.0), 12.0)):
        config = EnvConfig(observation="none", wind=wind, max_duration_s=duration)
        env = WildfireVecEnv(config, 1)
        env.reset([3])
        episode = FireEpisode(3, env.shapes[0], wind, max_decisions=decisions_in(duration))
        while not env.done[0]:
            result = env.step(np.zeros((1, 2), dtype=np.int64))
            stepped = episode.advance()
            assert stepped == (env.decisions[0] % DECISIONS_PER_FIRE_STEP == 0)
            np.testing.assert_array_equal(episode.burning, env.fire.burning[0])
        assert episode.decisions == env.decisions[0]
        assert episode.phase == ("terminated" if result.terminated[0] else "truncated")


def test_defaults_are_written_once() -> None:
    config = EnvConfig()
    assert config.preburn_steps == EPISODE_DEFAULTS.preburn_steps
    assert config.border_cells == EPISODE_DEFAULTS.border_cells
    assert config.max_duration_s == EPISODE_DEFAULTS.duration_s
    assert config.max_wind == EPISODE_DEFAULTS.max_wind
    assert config.shapes == (EPISODE_DEFAULTS.shape,)
    assert config.max_decisions == decisions_in(EPISODE_DEFAULTS.duration_s) == 4000


def test_config_files_agree_with_the_episode_defaults() -> None:
    assert CONFIG_FILES, "no config/*.yaml found"
    defaults = asdict(EPISODE_DEFAULTS)
    checked: set[str] = set()
    for path in CONFIG_FILES:
        for node, section in (yaml.safe_load(path.read_text()) or {}).items():
            parameters = (
                (section or {}).get("ros__parameters", {}) if isinstance(section, dict) else {}
            )
            for key, value in parameters.items():
                if key in defaults:
                    assert value == defaults[key], f"{path.name} {node} {key}: {value!r}"
                    assert type(value) is type(defaults[key]), f"{path.name} {node} {key}"
                    checked.add(key)
    # The fire simulator's episode parameters are all in the shipped file.
    assert checked >= {f.name for f in fields(EpisodeDefaults)} - {"max_wind"}


@pytest.mark.parametrize("geometry", [MapGeometry(), MapGeometry(120, 160)])
def test_the_ignition_without_a_fire_is_the_fires_start(geometry: MapGeometry) -> None:
    # The aggregator, the monitor and the agents' replicas start from `ignite` (no torch); the
    # fire simulator from a stepped BatchedFire: they must start from the same fire.
    for shape in Shape:
        for seed in (0, 7, 2_000_003):
            fire = initial_fire(seed, shape, (0.3, -0.2), geometry)
            ignition = ignite(seed, shape, geometry)
            np.testing.assert_array_equal(ignition.burning, fire.burning[0])
            np.testing.assert_array_equal(ignition.fuel, fire.initial_fuel[0])
            assert ignition.burning.any()
    # Ignition cells without fuel do not burn, on either path.
    params = FireParams(fuel_min=0, fuel_max=1)
    fire = BatchedFire(1, params, geometry)
    masks = shape_masks(Shape.CIRCULAR, geometry)
    fire.reset([0], [3], masks.ignition, masks.fuel, np.zeros(2))
    ignition = ignite(3, Shape.CIRCULAR, geometry, params)
    np.testing.assert_array_equal(ignition.burning, fire.burning[0])
    assert ignition.burning.sum() < masks.ignition.sum()


def test_processes_that_only_start_a_fire_do_not_load_torch() -> None:
    # About 1.5 s of CPU per process: the launcher, the aggregator and the agents' radio.
    script = (
        "import sys\n"
        "import wildfire_world.config, wildfire_belief.filtered_aggregator\n"
        "import wildfire_bringup.monitor_protocol, wildfire_agent.agent_parameters\n"
        "from wildfire_sim.ignition import ignite\n"
        "ignite(5, 't')\n"
        "assert 'torch' not in sys.modules, 'torch was loaded'\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
