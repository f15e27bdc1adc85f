"""Noisy sensing of a batch of episodes: the sensors' reports, the filtered team belief, the
score under noise (docs/model.md, Realistic sensing).

:class:`TeamSensing` is what :class:`~wildfire_world.env.WildfireVecEnv` keeps when the
sensor is not the paper's perfect disc (``--sensor camera``, or any ``--pixel-error``). Each
decision:

1. the team belief's clock ticks, and when the fire stepped its process term moves the
   belief one fire step (``wildfire_belief.filtered_belief.LogOddsBelief.predict``);
2. every aircraft's sensor reports the cells it sees: the four cameras
   (``wildfire_agent.camera``) or the 100 m disc, each seen cell's true value flipped with
   probability p, drawn from the aircraft's own stream (``seeding.Stream.SENSOR``), so an
   aircraft reports the same whatever the batch;
3. the belief fuses every report of every aircraft (exact Bayes in log-odds);
4. the score (``wildfire_belief.filtered_aggregator.score_decision``): a cell scores when it is
   truly burning, was believed not burning before the decision and is believed burning
   after it, **at most once per episode** (flicker cannot be farmed). A cell that turns
   believed burning while truly not burning is a false alarm.

The belief aggregator node and the run monitor keep the same belief of one episode
(``wildfire_belief.filtered_aggregator.FilteredAggregator``), in the same order.

The belief network sees the belief in the whole percent the aggregator publishes
(:meth:`TeamSensing.probability`), so an agent node's network sees exactly its input here.

The flipped fraction (reports that disagree with the truth over all reports) is kept per
episode, to check the noise is what was asked for.

With ``wind_filter`` each team also runs a particle filter over the wind
(``wildfire_belief.wind_filter``, 40 mean-field fire models weighted by the reports): at
every fire step the belief's process term takes the filter's wind estimate.
"""

from __future__ import annotations

import numpy as np

from wildfire_agent import camera
from wildfire_agent.aircraft_sensor import sensor_windows
from wildfire_agent.camera_view import BURNING, CLEAR, NOTHING
from wildfire_agent.dynamics import AircraftState
from wildfire_belief.filtered_aggregator import score_decision
from wildfire_belief.filtered_belief import LogOddsBelief
from wildfire_belief.sensors import NUM_CAMERAS
from wildfire_belief.wind_filter import WindFilter, team_wind_filter
from wildfire_belief.window_runs import WindowRuns
from wildfire_msgs_py.belief_codec import published_probability
from wildfire_sim.grid import PAPER_MAP, MapGeometry
from wildfire_sim.seeding import Stream, generator


class TeamSensing:
    """Noisy reports and the filtered team belief of ``num_envs`` episodes of ``n`` aircraft."""

    def __init__(
        self,
        sensor: str,
        pixel_error: float,
        num_envs: int,
        n: int,
        preburn_steps: int,
        wind_filter: bool = False,
        keep_codes: bool = False,
        geometry: MapGeometry = PAPER_MAP,
        keep_reports: bool = False,
    ) -> None:
        self.sensor = sensor
        self.geometry = geometry
        self.pixel_error = pixel_error
        self.n = n
        self.preburn_steps = preburn_steps
        self.belief = LogOddsBelief(num_envs, pixel_error, geometry=geometry)
        shape = (num_envs, *geometry.shape)
        self._probability = np.zeros(shape)
        self.scored = np.zeros(shape, dtype=bool)
        """Cells that have scored this episode (each scores at most once)."""
        self.false_alarms = np.zeros(num_envs, dtype=np.int64)
        self.reports = np.zeros(num_envs, dtype=np.int64)
        self.flipped = np.zeros(num_envs, dtype=np.int64)
        self.rngs: list[list[np.random.Generator]] = [[] for _ in range(num_envs)]
        self.wind_filter = wind_filter
        self.filters: list[WindFilter | None] = [None] * num_envs
        self.codes: np.ndarray | None = None
        """With ``keep_codes``: each aircraft's reports of the last decision as codes in its
        sensor windows (``camera_view.report_codes``), (E, N, C, side, side) uint8, for the
        observation approach; all ``NOTHING`` before an episode's first decision."""
        self.code_origin = (np.zeros((num_envs, n), np.int64), np.zeros((num_envs, n), np.int64))
        """(row0, col0) (E, N) of the windows of :attr:`codes`."""
        self.keep_reports = keep_reports
        self.sent: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        """With ``keep_reports``: each (episode, aircraft)'s reports of the last decision,
        (flat cells, values), for the radio messages under limited links."""
        if keep_codes:
            if sensor != "camera":
                raise ValueError("report codes are kept for camera sensing only")
            side = camera.CAMERA_WINDOW
            self.codes = np.zeros((num_envs, n, NUM_CAMERAS, side, side), dtype=np.uint8)

    def reset(
        self, env_ids: np.ndarray, seeds: np.ndarray, ignition: np.ndarray, fuel: np.ndarray
    ) -> None:
        """Start over: the belief from the ignition seed, spread over the pre-burn (the team
        knows the episode's rules, not its draws); fresh sensor streams."""
        self.belief.reset(env_ids, ignition, fuel, self.preburn_steps)
        self.scored[env_ids] = False
        self.false_alarms[env_ids] = 0
        self.reports[env_ids] = 0
        self.flipped[env_ids] = 0
        if self.codes is not None:
            self.codes[env_ids] = NOTHING
        for i, (e, seed) in enumerate(zip(env_ids.tolist(), seeds.tolist(), strict=True)):
            self.rngs[e] = [generator(seed, Stream.SENSOR, k) for k in range(self.n)]
            if self.wind_filter:
                self.filters[e] = team_wind_filter(
                    seed, self.pixel_error, ignition[i], fuel[i], self.preburn_steps
                )

    def sense(
        self, active: np.ndarray, pose: AircraftState, truth: np.ndarray, fire_stepped: np.ndarray
    ) -> np.ndarray:
        """One decision of the ``active`` episodes (see the module docstring); returns the
        team reward (E,) int64: cells that scored now."""
        # Compiled (numba, loaded with the belief's kernels): imported here, not by every
        # user of the environment.
        from wildfire_belief.belief_kernels import window_reports

        envs = np.flatnonzero(active)
        belief = self.belief
        before = belief.believed()
        belief.tick(envs)
        stepped = np.flatnonzero(fire_stepped & active)
        for e in stepped.tolist() if self.wind_filter else ():
            particles = self.filters[e]
            assert particles is not None
            particles.steer(belief, e)
        if stepped.size:
            belief.predict(stepped)
        windows = sensor_windows(self.sensor, pose, self.geometry)
        rngs = [rng for e in envs.tolist() for rng in self.rngs[e]]
        runs = WindowRuns(*(bound[envs] for bound in windows.runs))
        uniforms = camera.report_uniforms(runs, rngs)
        lead = (envs.size * self.n, *runs.first.shape[2:])  # (aircraft, sensor, row)
        codes = np.zeros((0, 0, 0, 0), np.uint8)
        if self.codes is not None:
            codes = np.full((*lead, self.codes.shape[-1]), NOTHING, np.uint8)
        # One compiled pass from the runs to the reports (and codes): each seen cell in
        # run_cells order, its uniform, its truth (a seen cell is always on the map).
        env, cell, value, wrong = window_reports(
            runs.first.reshape(lead),
            runs.stop.reshape(lead),
            windows.row0[envs].reshape(-1),
            windows.col0[envs].reshape(-1),
            np.repeat(envs, self.n),
            np.ascontiguousarray(truth, dtype=bool).reshape(-1),
            uniforms,
            self.pixel_error,
            self.geometry.cols,
            self.geometry.cells,
            codes,
            CLEAR,
            BURNING,
        )
        if self.keep_reports:
            # Each aircraft's reports are one block of the output, in (episode, aircraft) order.
            counts = np.maximum(runs.stop - runs.first, 0).reshape(envs.size * self.n, -1).sum(1)
            bounds = np.cumsum(counts)[:-1]
            senders = [(e, k) for e in envs.tolist() for k in range(self.n)]
            parts = zip(np.split(cell, bounds), np.split(value, bounds), strict=True)
            self.sent = dict(zip(senders, parts, strict=True))
        self.reports += np.bincount(env, minlength=len(active))
        self.flipped += np.bincount(env[wrong], minlength=len(active))
        belief.update(env, cell, value)
        if self.codes is not None:
            self.codes[envs] = codes.reshape(envs.size, *self.codes.shape[1:])
            self.code_origin = (windows.row0.copy(), windows.col0.copy())
        if self.wind_filter:
            for e in envs.tolist():
                particles = self.filters[e]
                assert particles is not None
                mine = env == e
                particles.observe(cell[mine], value[mine])
        # Only active episodes' beliefs moved (ticks, fire steps and reports are theirs),
        # so only they can score.
        scores, alarms = score_decision(before, belief.believed(), truth, self.scored)
        self.false_alarms += alarms
        return scores

    def probability(self) -> np.ndarray:
        """The filtered belief as the aggregator publishes it, (E, H, W) float32: the
        probability of burning in whole percent, on the believed side of 50."""
        # The float64 probability is rounded at once: one buffer for every decision.
        probability = self.belief.probability(out=self._probability)
        return published_probability(self.belief.believed(), probability)

    def flipped_fraction(self) -> np.ndarray:
        """Reports that disagreed with the truth, over all reports, per episode."""
        return self.flipped / np.maximum(self.reports, 1)


__all__ = ["TeamSensing"]
