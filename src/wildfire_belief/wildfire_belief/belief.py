"""The belief map shared by the team (docs/model.md, Shared belief), batched over environments.

Per cell: believed burning (bool) and the time since the cell was last visited, capped at
255 s. Time is counted in integer deciseconds (one decision = 1 ds), so ages are exact and
runs are bit-reproducible; ``age_s()`` converts. Rather than ageing every cell each
decision, the map stores the time of each cell's last visit: a decision then only touches
the few hundred visited cells, and ages are computed when an image or message needs them.

Team reward of a decision = number of visited cells believed not burning that are burning
(each cell counted once however many aircraft see it).
"""

from __future__ import annotations

import numpy as np

from wildfire_sim.grid import PAPER_MAP, MapGeometry

AGE_CAP_S = 255.0
"""Ages saturate here (and an unvisited cell starts here)."""
TICKS_PER_S = 10
"""Belief clock resolution: one tick per decision (0.1 s)."""
AGE_CAP_TICKS = int(AGE_CAP_S * TICKS_PER_S)


class SharedBelief:
    """Belief maps of ``num_envs`` environments.

    Arrays: ``burning`` (E, H, W) bool; ``last_visit`` (E, H, W) int32 tick of the last
    visit; ``now`` (E,) int64 current tick.
    """

    def __init__(self, num_envs: int, geometry: MapGeometry = PAPER_MAP) -> None:
        self.geometry = geometry
        self.burning = np.zeros((num_envs, *geometry.shape), dtype=bool)
        # int32: 6.8 years of decisions, and half the bytes of a field map's clock.
        self.last_visit = np.full((num_envs, *geometry.shape), -AGE_CAP_TICKS, np.int32)
        self.now = np.zeros(num_envs, dtype=np.int64)

    @property
    def num_envs(self) -> int:
        return self.burning.shape[0]

    def reset(self, env_ids: np.ndarray | list[int], believed_burning: np.ndarray) -> None:
        """Start over: believed burning = ``believed_burning`` (the ignition seed), age = cap."""
        env_ids = np.atleast_1d(np.asarray(env_ids, dtype=np.int64))
        self.burning[env_ids] = believed_burning
        self.now[env_ids] = 0
        self.last_visit[env_ids] = -AGE_CAP_TICKS

    def tick(self, env_ids: np.ndarray | None = None) -> None:
        """Advance the clock of every (or the given) environment by one decision."""
        if env_ids is None:
            self.now += 1
        else:
            self.now[env_ids] += 1

    def visit(self, env: np.ndarray, cell: np.ndarray, truth: np.ndarray) -> np.ndarray:
        """Apply visits, return the team reward per environment, (E,) int64.

        ``env``/``cell`` are the visited cells (as from ``visits.visited_cells``: no
        duplicates) and ``truth`` the true burning value of each, at the current tick.
        """
        # Flat 1-D indices: numpy gathers and scatters them far faster than (env, cell) pairs.
        flat = env * self.geometry.cells + cell
        burning = self.burning.reshape(-1)
        newly_seen = truth & ~burning[flat]
        reward = np.bincount(env[newly_seen], minlength=self.num_envs)
        burning[flat] = truth
        self.last_visit.reshape(-1)[flat] = self.now[env]
        return reward.astype(np.int64)

    def age_ticks(self) -> np.ndarray:
        """Deciseconds since each cell was last visited, capped, (E, H, W) int64."""
        return np.minimum(self.now[:, None, None] - self.last_visit, AGE_CAP_TICKS)

    def age_s(self) -> np.ndarray:
        """Seconds since each cell was last visited, capped at 255, (E, H, W) float32."""
        return age_seconds(self.now[:, None, None], self.last_visit)

    def age_window(self, env: int, rows: slice, cols: slice) -> np.ndarray:
        """:meth:`age_s` of one environment's window, (h, w) float32 (an ego image's)."""
        return age_seconds(self.now[env], self.last_visit[env, rows, cols])


def age_seconds(now: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Seconds from tick ``last`` to tick ``now`` (broadcast), capped at 255, float32: the
    age of a cell, ``min(now - last, AGE_CAP_TICKS) / TICKS_PER_S``.

    Computed in float32, in one array: ticks and their differences are integers far below
    2**24, so exact in float32, and every capped age divided in float32 equals the float64
    quotient rounded to float32 (all 2 551 of them, tested). Three map-sized int64 and
    float64 temporaries cost ~3 ms a decision at 64 episodes, in page faults more than in
    arithmetic.
    """
    age = np.subtract(now, last, dtype=np.float32)
    np.minimum(age, np.float32(AGE_CAP_TICKS), out=age)
    age /= np.float32(TICKS_PER_S)
    return age


def belief_iou(believed: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Intersection over union of believed-burning and burning cells, per environment."""
    believed, truth = np.asarray(believed, bool), np.asarray(truth, bool)
    axes = tuple(range(1, believed.ndim))
    union = (believed | truth).sum(axis=axes)
    intersection = (believed & truth).sum(axis=axes)
    return np.where(union > 0, intersection / np.maximum(union, 1), 1.0)


def mean_age_at_burning(age_s: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Mean belief age (s) over the truly burning cells, per environment (NaN if none)."""
    truth = np.asarray(truth, bool)
    axes = tuple(range(1, truth.ndim))
    count = truth.sum(axis=axes)
    total = np.where(truth, age_s, 0.0).sum(axis=axes)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def score_ceiling(burned_in_flight: np.ndarray, believed_at_start: np.ndarray) -> np.ndarray:
    """Most score a team could have made, per environment: cells that burned at some decision
    of the flight (``burned_in_flight``) and were not believed burning at its start.

    A cell scores when it is seen burning while believed not burning; the belief then says
    burning, and says "not burning" again only once the cell is seen burnt out, which it
    stays. So a cell scores at most once, and only while it burns.
    """
    scorable = np.asarray(burned_in_flight, bool) & ~np.asarray(believed_at_start, bool)
    return scorable.sum(axis=tuple(range(1, scorable.ndim)))


__all__ = [
    "AGE_CAP_S",
    "AGE_CAP_TICKS",
    "TICKS_PER_S",
    "SharedBelief",
    "age_seconds",
    "belief_iou",
    "mean_age_at_burning",
    "score_ceiling",
]
