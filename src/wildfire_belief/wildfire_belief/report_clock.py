"""What both forms of the filtered belief keep besides the belief itself: the clock of
each batch of episodes and the tick of each cell's last report, from which its age follows
(:class:`ReportClock`), and the environment ids a call applies to (:func:`as_ids`).
"""

from __future__ import annotations

import numpy as np

from wildfire_belief.belief import AGE_CAP_TICKS, age_seconds
from wildfire_sim.grid import MapGeometry


def as_ids(env_ids: np.ndarray | list[int] | None, num_envs: int) -> np.ndarray:
    if env_ids is None:
        return np.arange(num_envs)
    return np.atleast_1d(np.asarray(env_ids, dtype=np.int64))


class ReportClock:
    """The belief clock and the tick of each cell's last report (shared by both forms).

    Arrays: ``now`` (E,) int64 current tick; ``last_report`` (E, H, W) int64.
    """

    def __init__(self, num_envs: int, geometry: MapGeometry) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs: expected >= 1, got {num_envs}")
        self.geometry = geometry
        self.now = np.zeros(num_envs, dtype=np.int64)
        shape = (num_envs, *geometry.shape)
        self.last_report = np.full(shape, -AGE_CAP_TICKS, dtype=np.int64)

    @property
    def num_envs(self) -> int:
        return self.now.shape[0]

    def tick(self, env_ids: np.ndarray | list[int] | None = None) -> None:
        """Advance the clock of every (or the given) environment by one decision."""
        if env_ids is None:
            self.now += 1
        else:
            self.now[as_ids(env_ids, self.num_envs)] += 1

    def age_ticks(self) -> np.ndarray:
        """Deciseconds since each cell was last reported, capped, (E, H, W) int64."""
        return np.minimum(self.now[:, None, None] - self.last_report, AGE_CAP_TICKS)

    def age_s(self) -> np.ndarray:
        """Seconds since each cell was last reported, capped at 255, (E, H, W) float32."""
        return age_seconds(self.now[:, None, None], self.last_report)

    def age_window(self, env: int, rows: slice, cols: slice) -> np.ndarray:
        """:meth:`age_s` of one environment's window, (h, w) float32 (an ego image's)."""
        return age_seconds(self.now[env], self.last_report[env, rows, cols])

    def _reset_clock(self, env_ids: np.ndarray) -> None:
        self.now[env_ids] = 0
        self.last_report[env_ids] = -AGE_CAP_TICKS

    def _checked_reports(
        self, env: np.ndarray, cell: np.ndarray, value: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Validate a batch of reports: (environment, flat index into the batch, value)."""
        env = np.asarray(env, dtype=np.int64).reshape(-1)
        cell = np.asarray(cell, dtype=np.int64).reshape(-1)
        value = np.asarray(value, dtype=bool).reshape(-1)
        if not env.size == cell.size == value.size:
            raise ValueError(
                f"env, cell and value must have one entry per report, got "
                f"{env.size}, {cell.size} and {value.size}"
            )
        cells = self.geometry.cells
        if env.size and (
            env.min() < 0 or env.max() >= self.num_envs or cell.min() < 0 or cell.max() >= cells
        ):
            raise ValueError("a report names an environment or a cell outside the belief")
        return env, env * cells + cell, value

    def _flat_reports(
        self, env: np.ndarray, cell: np.ndarray, value: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Validate a batch of reports, stamp their cells, return (flat index, value)."""
        env, flat, value = self._checked_reports(env, cell, value)
        self.last_report.reshape(-1)[flat] = self.now[env]
        return flat, value


__all__ = ["ReportClock", "as_ids"]
