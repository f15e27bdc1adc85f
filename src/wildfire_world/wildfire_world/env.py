"""Batched multi-agent wildfire surveillance environment.

:class:`WildfireVecEnv` steps ``num_envs`` independent episodes of ``n_aircraft`` aircraft at
once (a leading environment dimension on every array, done masks instead of branches), in
the style of Gymnasium's vector environments; :mod:`wildfire_world.parallel_env` wraps one
episode as a PettingZoo ``ParallelEnv``. It composes the pure modules the ROS nodes use —
fire (``wildfire_sim``), dynamics, sensor, rewards (``wildfire_agent``), belief
(``wildfire_belief``) — so the distributed system computes exactly what this computes.

Action space
    Per aircraft, ``Discrete(2)``: 0 banks -5 degrees, 1 banks +5 degrees (limit 50 degrees).
Observation space (``observation="obs"`` or ``"belief"``)
    ``image``: the sensor image (1, 30, 40) in {0, 1} (under camera sensing the four camera
    images (4, 30, 20) in {0, 0.5, 1}: ``wildfire_agent.camera_view``), or the ego belief
    image (2, 100, 100) in [0, 1]; ``state``: normalised pairwise states (K, 5),
    K = max(min(N - 1, 8), 1): the nearest 8 peers in a larger fleet
    (``pairwise.nearest_others``).
    ``observation="none"`` skips images (for the receding-horizon and random policies).
Rewards
    ``reward="obs"``: the observation-based reward r1 + r2 + r3 + r4 of each aircraft (under
    camera sensing computed from its cameras' reports, never from the truth).
    ``reward="belief"``: the team reward (newly seen burning cells) minus
    ``belief_proximity_weight * sum_j exp(-rho_j / c)``. Either way ``team_reward`` (the
    score increment, docs/model.md, Evaluation) is returned too, and ``scores`` accumulates it.
Starting state
    Episode seed -> shape (uniform over ``shapes``), wind (uniform in [-max_wind, max_wind]^2
    unless fixed), fuel, start poses 150-300 m around the seed at uniform bearing and heading
    (with several fires, aircraft k around fire k mod K: ``shapes.start_centres_m``).
    The fire starts as the landscape says (``wildfire_sim.landscape``: a fuel raster, an
    ignition raster or ``ignitions`` seeded blocks; by default the paper's fuel and the
    named shape) and pre-burns ``preburn_steps`` fire steps, or until it has touched
    ``preburn_area_m2``; the belief starts as the ignition seed with every age at 255 s.
Episode end
    The rules of ``wildfire_sim.episode`` (the one rule book): terminated when, after a fire
    step, a burning cell lies within ``border_cells`` of the map edge; truncated after
    ``max_duration_s``. The fire never depends on the aircraft, so a seed fixes the episode
    length for every policy.
Decision order (one ``step``)
    bank action -> fly 0.1 s -> every ``DECISIONS_PER_FIRE_STEP``-th decision a fire step ->
    cells within 100 m of any aircraft are visited (belief <- truth, age <- 0) -> radio
    messages (under limited links) -> rewards -> end check.
Radio links (``comm``)
    ``ideal`` (the default) keeps one belief shared by the team, as in the paper. Any other
    model (``wildfire_belief.radio``) gives every aircraft its own belief replica, merged from
    its own visits and the peers' radio messages it hears, and its own view of the peers'
    poses (heard, then dead-reckoned: ``wildfire_agent.heard_poses``). Each aircraft observes
    and decides on its own replica and view; the score stays the union of every visit.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol

import numpy as np

from wildfire_agent import dynamics, pairwise
from wildfire_agent.approaches import (
    Approach,
    belief_images,
    belief_rewards,
    sensor_images,
)
from wildfire_agent.camera_view import camera_images, camera_rewards
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.rewards import (
    FireFieldMaps,
    distance_to_fire,
    fire_field_maps,
    observation_rewards,
)
from wildfire_belief.belief import SharedBelief
from wildfire_belief.visits import visit_windows, visited_cells, window_values
from wildfire_sim.episode import (
    DECISIONS_PER_FIRE_STEP,
    fire_at_border,
    preburn,
)
from wildfire_sim.fire import BatchedFire
from wildfire_sim.shapes import Shape
from wildfire_world.config import (
    OBSERVATION_KINDS,
    REWARD_KINDS,
    EnvConfig,
    Scenario,
    draw_scenario,
)
from wildfire_world.errors import WorldError
from wildfire_world.team_radio import TeamRadio
from wildfire_world.team_report_radio import TeamReportRadio
from wildfire_world.team_sensing import TeamSensing


class StepResult(NamedTuple):
    """What :meth:`WildfireVecEnv.step` returns; arrays lead with the environment dim."""

    observations: dict[str, np.ndarray]
    rewards: np.ndarray
    """(E, N) float64: per-aircraft training reward (0 in finished environments)."""
    team_reward: np.ndarray
    """(E,) int64: newly seen burning cells this decision (the score increment)."""
    terminated: np.ndarray
    """(E,) bool: fire reached the border this decision."""
    truncated: np.ndarray
    """(E,) bool: time limit reached this decision."""


class WildfireVecEnv:
    """``num_envs`` wildfire episodes stepped together (see the module docstring)."""

    def __init__(self, config: EnvConfig, num_envs: int) -> None:
        self.config = config.validate()
        if num_envs < 1:
            raise WorldError(f"num_envs: expected >= 1, got {num_envs}")
        self.num_envs = num_envs
        n = config.n_aircraft
        self.geometry = config.geometry
        self.fire = BatchedFire(num_envs, config.fire, config.geometry, config.ground.fuel)
        self.belief = SharedBelief(num_envs, config.geometry)
        self.aircraft = AircraftState(
            x_m=np.zeros((num_envs, n)),
            y_m=np.zeros((num_envs, n)),
            heading_rad=np.zeros((num_envs, n)),
            bank_steps=np.zeros((num_envs, n), dtype=np.int64),
        )
        self.seeds = np.zeros(num_envs, dtype=np.int64)
        self.shapes: list[Shape] = [Shape.CIRCULAR] * num_envs
        self.decisions = np.zeros(num_envs, dtype=np.int64)
        self.scores = np.zeros(num_envs, dtype=np.int64)
        self.done = np.ones(num_envs, dtype=bool)
        self.terminated = np.zeros(num_envs, dtype=bool)
        self._maps: FireFieldMaps | None = None
        self._maps_stale = np.ones(num_envs, dtype=bool)
        # C-contiguous copy of the burning grids, refreshed when fires step: sensors and
        # visits read it every decision, and the fire model stores its grids env-last.
        self.truth = np.ascontiguousarray(self.fire.burning)
        self.radio: TeamRadio | TeamReportRadio | None = None
        if not config.comm.ideal and config.noisy:
            self.radio = TeamReportRadio(
                config.comm, num_envs, n, config.pixel_error, config.preburn_steps, config.geometry
            )
        elif not config.comm.ideal:
            self.radio = TeamRadio(config.comm, num_envs, n, config.geometry)
        self.sensing = None
        if config.noisy:
            self.sensing = TeamSensing(
                config.sensor,
                config.pixel_error,
                num_envs,
                n,
                config.preburn_steps,
                config.wind_filter,
                keep_codes=config.camera_view,
                geometry=config.geometry,
                keep_reports=self.radio is not None,
            )

    # ------------------------------------------------------------------ reset
    def reset(
        self, seeds: np.ndarray | list[int], env_ids: np.ndarray | list[int] | None = None
    ) -> dict[str, np.ndarray]:
        """Start new episodes with ``seeds`` in ``env_ids`` (default: all environments)."""
        env_ids = np.arange(self.num_envs) if env_ids is None else np.asarray(env_ids, np.int64)
        seeds = np.asarray(seeds, dtype=np.int64).reshape(-1)
        if seeds.size != env_ids.size:
            raise WorldError(f"reset: got {seeds.size} seeds for {env_ids.size} environments")
        if np.any(seeds < 0):
            raise WorldError("seed: expected numbers >= 0")
        scenarios = [draw_scenario(int(seed), self.config) for seed in seeds]
        masks = [s.masks for s in scenarios]
        self.fire.reset(
            env_ids,
            seeds,
            np.stack([m.ignition for m in masks]),
            np.stack([m.fuel for m in masks]),
            np.stack([s.wind for s in scenarios]),
        )
        self.belief.reset(env_ids, self.fire.burning[env_ids])
        fuel = np.stack([m.fuel for m in masks])
        if isinstance(self.radio, TeamReportRadio):
            self.radio.reset(env_ids, self.fire.burning[env_ids], fuel)
        elif self.radio is not None:
            self.radio.reset(env_ids, self.fire.burning[env_ids])
        if self.sensing is not None:
            self.sensing.reset(env_ids, seeds, self.fire.burning[env_ids], fuel)
        starting = np.zeros(self.num_envs, dtype=bool)
        starting[env_ids] = True
        c = self.config
        preburn(self.fire, starting, c.preburn_steps, c.preburn_area_m2, c.border_cells)
        for k, (env, scenario) in enumerate(zip(env_ids.tolist(), scenarios, strict=True)):
            for field_now, field_start in zip(self.aircraft, scenario.start, strict=True):
                field_now[env] = field_start
            self.shapes[env] = scenario.shape
            self.seeds[env] = seeds[k]
        self.decisions[env_ids] = 0
        self.scores[env_ids] = 0
        self.terminated[env_ids] = fire_at_border(
            self.fire.burning[env_ids], self.config.border_cells
        )
        self.done[env_ids] = self.terminated[env_ids]
        self._maps_stale[env_ids] = True
        self.truth = np.ascontiguousarray(self.fire.burning)
        if self.radio is not None:
            self.radio.heard.reset(env_ids, AircraftState(*(f[env_ids] for f in self.aircraft)))
        return self.observe()

    # ------------------------------------------------------------------- step
    def step(self, actions: np.ndarray) -> StepResult:
        """Advance every unfinished environment by one decision with ``actions`` (E, N)."""
        actions = np.asarray(actions, dtype=np.int64)
        if actions.shape != (self.num_envs, self.config.n_aircraft):
            raise WorldError(
                f"actions: expected shape {(self.num_envs, self.config.n_aircraft)}, "
                f"got {actions.shape}"
            )
        active = ~self.done
        moved = dynamics.step(self.aircraft, actions)
        for field_now, field_moved in zip(self.aircraft, moved, strict=True):
            field_now[active] = field_moved[active]
        self.decisions += active
        fire_due = active & (self.decisions % DECISIONS_PER_FIRE_STEP == 0)
        if fire_due.any():
            self.fire.step(fire_due)
            self.truth = np.ascontiguousarray(self.fire.burning)
            self._maps_stale |= fire_due
        if self.sensing is not None:
            team_reward = self.sensing.sense(active, self.aircraft, self.truth, fire_due)
            if isinstance(self.radio, TeamReportRadio):
                self.radio.send(
                    active, self.decisions, self.seeds, self.aircraft, self.sensing.sent, fire_due
                )
        else:
            team_reward = self._visit(active)
        self.scores += team_reward

        weights, a = self.config.obs_weights, self.aircraft
        if self.config.reward == Approach.OBS and self.config.camera_view:
            rewards = camera_rewards(*self._camera_reports(), a, weights)
        elif self.config.reward == Approach.OBS:
            rewards = observation_rewards(self.maps, a.x_m, a.y_m, a.bank_rad, weights)
        else:
            rewards = belief_rewards(team_reward, a, weights, self.config.belief_proximity_weight)
        rewards = np.where(active[:, None], rewards, 0.0)

        terminated = np.zeros(self.num_envs, dtype=bool)
        if fire_due.any():
            due = np.flatnonzero(fire_due)
            terminated[due] = fire_at_border(self.truth[due], self.config.border_cells)
        truncated = active & ~terminated & (self.decisions >= self.config.max_decisions)
        self.terminated |= terminated
        self.done |= terminated | truncated
        return StepResult(self.observe(), rewards, team_reward, terminated, truncated)

    def _visit(self, active: np.ndarray) -> np.ndarray:
        """Visit the cells near every aircraft of active environments; team reward (E,)."""
        self.belief.tick(np.flatnonzero(active))
        windows = visit_windows(self.aircraft.x_m, self.aircraft.y_m, self.geometry)
        env, cell = visited_cells(windows, self.geometry)
        keep = active[env]
        env, cell = env[keep], cell[keep]
        truth = self.truth.reshape(-1)[env * self.geometry.cells + cell]
        if isinstance(self.radio, TeamRadio):
            seen = window_values(self.truth, windows).astype(bool)
            self.radio.send(active, self.decisions, self.seeds, self.aircraft, windows, seen)
        return self.belief.visit(env, cell, truth)

    # ------------------------------------------------------------ observation
    @property
    def maps(self) -> FireFieldMaps:
        """Reward look-up data of the current fires (refreshed after fire steps)."""
        if self._maps is None:
            self._maps = fire_field_maps(self.truth, self.config.obs_weights)
        elif self._maps_stale.any():
            stale = np.flatnonzero(self._maps_stale)
            burning = self.truth
            distance = self._maps.distance_m
            distance[stale] = distance_to_fire(
                burning[stale], self.config.obs_weights.max_distance_m
            )
            self._maps = FireFieldMaps(burning=burning, distance_m=distance, clear_count=None)
        self._maps_stale[:] = False
        return self._maps

    def _camera_reports(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Report codes (E, N, 4, 61, 61) of the last decision and their windows' origin."""
        assert self.sensing is not None and self.sensing.codes is not None
        return (self.sensing.codes, *self.sensing.code_origin)

    def believed(self) -> np.ndarray:
        """What the team believes burning, (E, H, W) bool: the shared belief, or the filtered
        belief's probability > 0.5 under noisy sensing."""
        return self.belief.burning if self.sensing is None else self.sensing.belief.believed()

    def belief_probability(self) -> np.ndarray:
        """The probability of burning the belief images show, (E, H, W): the believed map
        (bool) under the paper's disc, the filtered belief in whole percent (as the
        aggregator publishes it) under noisy sensing."""
        return self.belief.burning if self.sensing is None else self.sensing.probability()

    def belief_age_s(self) -> np.ndarray:
        """Seconds since each cell was last visited (or reported), capped, (E, H, W)."""
        return self.belief.age_s() if self.sensing is None else self.sensing.belief.age_s()

    def believed_maps(self) -> FireFieldMaps:
        """Reward look-up data of what the team believes burning (``rh-belief`` plans on it):
        of the shared belief, (E, ...), or under limited links of each aircraft's replica,
        (E * N, ...)."""
        believed = self.believed() if self.radio is None else self.radio.believed()
        return fire_field_maps(believed, self.config.obs_weights)

    def team_views(self) -> AircraftState:
        """The team as each aircraft knows it, fields (E, N receivers, N aircraft).

        Ideal links: the true poses. Otherwise each aircraft's heard, dead-reckoned peers.
        """
        if self.radio is None:
            return AircraftState(
                *(np.broadcast_to(f[:, None, :], (*f.shape, f.shape[-1])) for f in self.aircraft)
            )
        n = self.config.n_aircraft
        return self.radio.heard.team(self.decisions, self.aircraft, np.arange(n))

    def pair_states(self) -> np.ndarray:
        """Normalised pairwise states (E, N, K, 5) float32, each from its aircraft's view."""
        if self.radio is None:
            return pairwise.normalise(pairwise.pairwise_states(self.aircraft))
        own = np.arange(self.config.n_aircraft)
        raw = pairwise.pairwise_states(self.team_views())  # (E, N, N, K, 5)
        return pairwise.normalise(raw[:, own, own])

    def observe(self) -> dict[str, np.ndarray]:
        """Observations of every aircraft (see the module docstring)."""
        kind = self.config.observation
        if kind == "none":
            return {"state": self.pair_states()}
        if kind == Approach.OBS and self.config.camera_view:
            images = camera_images(*self._camera_reports(), self.aircraft)
        elif kind == Approach.OBS:
            images = sensor_images(self.truth, self.aircraft)
        elif self.radio is None:
            clock = self.belief if self.sensing is None else self.sensing.belief
            images = belief_images(self.belief_probability(), clock.age_window, self.aircraft)
        else:
            images = self.radio.belief_images(self.aircraft)
        return {"image": images, "state": self.pair_states()}


class VecPolicy(Protocol):
    """A vector policy: chooses the actions of every aircraft of every episode of a
    :class:`WildfireVecEnv` (the implementations are in ``wildfire_learning.vec_policies``)."""

    observation: str
    """What the environment must render for it: ``obs``, ``belief`` or ``none``."""

    def reset(self, env: WildfireVecEnv) -> None:
        """Called after ``env.reset``: (re)seed per-aircraft randomness and plans."""

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        """Actions (E, N) int64."""


__all__ = [
    "OBSERVATION_KINDS",
    "REWARD_KINDS",
    "EnvConfig",
    "Scenario",
    "StepResult",
    "VecPolicy",
    "WildfireVecEnv",
    "draw_scenario",
]
