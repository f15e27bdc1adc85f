"""The filtered team belief of one episode under noisy sensing, fused from report windows.

Under the paper's perfect disc the team belief is :class:`~wildfire_belief.aggregator.
BeliefAggregator`: a visit sets a cell to its truth. Under noisy sensing (cameras, or any
pixel error) every report is one noisy look, and the belief is a probability per cell
(:class:`~wildfire_belief.filtered_belief.LogOddsBelief`). :class:`FilteredAggregator` is
that belief for one episode, as the belief aggregator node and the run monitor keep it; the
environment keeps a batch of the same belief (``wildfire_world.team_sensing``) and calls
the same rules in the same order, so a lockstep run equals ``wildfire eval`` bit for bit:

1. the clock ticks, and at a fire-step tick the process term moves the belief one step
   (with the wind filter, the filter steps first and hands its estimate to the process term);
2. every report of the tick, of every aircraft and sensor, is applied in one update (exact
   Bayes sums the reports, then clips once per cell: one call, whatever their order), and
   the wind filter weighs its particles by them;
3. :func:`score_decision` against the truth of the tick's fire step.

A report window is a window of the map (the visit window's encoding): ``visited`` is the
mask of cells the sensor saw, ``burning`` what it reported there.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wildfire_belief.aggregator import Window
from wildfire_belief.belief import TICKS_PER_S
from wildfire_belief.filtered_belief import LogOddsBelief
from wildfire_belief.wind_filter import WindFilter, team_wind_filter
from wildfire_sim.episode import DECISIONS_PER_FIRE_STEP, EPISODE_DEFAULTS
from wildfire_sim.grid import PAPER_MAP, MapGeometry
from wildfire_sim.ignition import ignite
from wildfire_sim.landscape import PAPER_LANDSCAPE, Landscape
from wildfire_sim.shapes import Shape


def score_decision(
    before: np.ndarray, after: np.ndarray, truth: np.ndarray, scored: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The score under noise of one decision, of (E, H, W) or one (H, W) map (bool each).

    A cell scores when it is truly burning, was believed not burning before the decision
    and is believed burning after it, and has not scored yet this episode: flicker cannot
    be farmed. A cell that turns believed burning while truly not burning is a false alarm.
    Adds the cells that score to ``scored`` (in place; C-contiguous) and returns the scores
    and the false alarms per episode, (E,) int64 (shape (1,) for one map).
    """
    from wildfire_belief.belief_kernels import score_cells

    if not scored.flags.c_contiguous:
        raise ValueError("scored must be C-contiguous (it is updated in place)")
    episodes = 1 if scored.ndim == 2 else scored.shape[0]
    scores, alarms = np.zeros(episodes, np.int64), np.zeros(episodes, np.int64)

    def flat(cells: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(cells, dtype=bool).reshape(-1)

    score_cells(flat(before), flat(after), flat(truth), scored.reshape(-1), scores, alarms)
    return scores, alarms


def report_cells(
    windows: Sequence[Window], geometry: MapGeometry = PAPER_MAP
) -> tuple[np.ndarray, np.ndarray]:
    """The reports of ``windows``, in their order: (flat cell index, reported value)."""
    cells, values = [], []
    for window in windows:
        i, j = np.nonzero(np.asarray(window.visited, dtype=bool))
        cells.append((window.row0 + i) * geometry.cols + window.col0 + j)
        values.append(np.asarray(window.burning, dtype=bool)[i, j])
    if not cells:
        return np.zeros(0, np.int64), np.zeros(0, bool)
    return np.concatenate(cells).astype(np.int64), np.concatenate(values)


class FilteredAggregator:
    """The filtered belief of episode ``seed`` from every report, with its score.

    The interface of :class:`~wildfire_belief.aggregator.BeliefAggregator` (``burning``,
    ``ticks``, ``age_s``, ``score``, ``merge``), plus the probability and false alarms.
    """

    def __init__(
        self,
        seed: int,
        shape: Shape | str,
        pixel_error: float,
        preburn_steps: int = EPISODE_DEFAULTS.preburn_steps,
        wind_filter: bool = False,
        ground: Landscape = PAPER_LANDSCAPE,
        border_cells: int = EPISODE_DEFAULTS.border_cells,
    ) -> None:
        masks = ground.start(Shape.parse(str(shape)), seed, border_cells)
        ignition = ignite(seed, shape, ground, border_cells=border_cells).burning
        self.belief = LogOddsBelief(1, pixel_error, geometry=ground.geometry)
        # The published grid's compiled rounding (numba), loaded now, not in the first
        # real-time tick.
        from wildfire_msgs_py.percent_kernels import compile_kernels

        compile_kernels()
        # The team knows the episode's rules, not its draws: the ignition seed spread over
        # the pre-burn, as the environment starts it.
        self.belief.reset([0], ignition, masks.fuel, preburn_steps)
        self.wind: WindFilter | None = None
        """The team's wind filter (``wind_filter``): its estimate drives the process term."""
        if wind_filter:
            self.wind = team_wind_filter(seed, pixel_error, ignition, masks.fuel, preburn_steps)
        self.scored = np.zeros(self.belief.geometry.shape, dtype=bool)
        self.score = 0
        self.false_alarms = 0
        self.reports = 0
        self.flipped = 0
        """Reports, and those that disagreed with the truth (scored ticks only)."""

    @property
    def burning(self) -> np.ndarray:
        """(H, W) bool believed burning (probability > 0.5)."""
        return self.belief.believed()[0]

    def probability(self) -> np.ndarray:
        """(H, W) float64 probability of burning."""
        return self.belief.probability()[0]

    @property
    def ticks(self) -> int:
        """Decisions merged so far."""
        return int(self.belief.now[0])

    def age_s(self) -> np.ndarray:
        """(H, W) float32 seconds since each cell was last reported (capped at 255)."""
        return self.belief.age_s()[0]

    def merge(self, windows: Sequence[Window], truth: np.ndarray | None = None) -> int:
        """One decision: tick (and at a fire step, predict), fuse ``windows``, score.

        ``truth`` is the true fire of the tick's fire step; without it (a ground station
        that does not see the fire) nothing is scored.
        """
        before = self.burning
        self.belief.tick()
        if self.ticks % DECISIONS_PER_FIRE_STEP == 0:
            if self.wind is not None:
                self.wind.steer(self.belief, 0)
            self.belief.predict()
        cell, value = report_cells(windows, self.belief.geometry)
        self.belief.update(np.zeros(cell.size, np.int64), cell, value)
        if self.wind is not None:
            self.wind.observe(cell, value)
        if truth is None:
            return 0
        truth = np.asarray(truth, dtype=bool)
        self.reports += cell.size
        self.flipped += int(np.count_nonzero(value != truth.reshape(-1)[cell]))
        scores, alarms = score_decision(before, self.burning, truth, self.scored)
        self.false_alarms += int(alarms[0])
        reward = int(scores[0])
        self.score += reward
        return reward

    def flipped_fraction(self) -> float:
        """Reports that disagreed with the truth, over all reports."""
        return self.flipped / max(self.reports, 1)

    def restore(self, time_s: float, score: float, believed: np.ndarray, age_s: np.ndarray) -> None:
        """Continue from an agent's copy (believed and ages only): each cell at the log-odds
        of one report's worth on its believed side, the probabilities themselves are lost."""
        belief = self.belief
        now = round(time_s * TICKS_PER_S)
        belief.now[0] = now
        weight = min(belief.report_log_odds, belief.max_log_odds)
        belief.log_odds[0] = np.where(np.asarray(believed, bool), weight, -weight)
        belief.last_report[0] = now - np.rint(np.asarray(age_s) * TICKS_PER_S).astype(np.int64)
        self.score = round(score)


__all__ = ["FilteredAggregator", "report_cells", "score_decision"]
