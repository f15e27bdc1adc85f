"""The follow-up's per-cell Kalman belief, kept to measure the shipped log-odds form against.

See :mod:`wildfire_belief.filtered_belief` (the module notes give the measurement): the same
interface, a scalar Kalman filter on x in [0, 1] per cell with Q = ``KALMAN_Q`` per predict
and R = ``KALMAN_R`` per report.
"""

from __future__ import annotations

import numpy as np

from wildfire_belief.filtered_belief import IGNITION_PROBABILITY
from wildfire_belief.report_clock import ReportClock, as_ids
from wildfire_sim.grid import PAPER_MAP, MapGeometry

KALMAN_Q = 0.01
"""Process variance the Kalman form adds per predict."""
KALMAN_R = 0.25
"""Measurement variance of one report in the Kalman form."""
KALMAN_INITIAL_VARIANCE = 0.1
"""Variance of every cell at reset (Kalman form): three true reports lift x = 0 above 0.5."""


class KalmanBelief(ReportClock):
    """The follow-up's per-cell scalar Kalman filter on x in [0, 1] (see the module notes).

    Parameters
    ----------
    num_envs : int
        Environments in the batch.
    q : float
        Variance added to every cell per :meth:`predict`.
    r : float
        Measurement variance of one report.
    geometry : MapGeometry
        The map (rows and columns of cells).

    Attributes
    ----------
    mean : (E, H, W) float64
        The estimate x, in [0, 1].
    variance : (E, H, W) float64
        Its variance.
    """

    def __init__(
        self,
        num_envs: int,
        q: float = KALMAN_Q,
        r: float = KALMAN_R,
        *,
        geometry: MapGeometry = PAPER_MAP,
    ) -> None:
        super().__init__(num_envs, geometry)
        if not q >= 0 or not r > 0:
            raise ValueError(f"q, r: expected q >= 0 and r > 0, got {q}, {r}")
        self.q, self.r = float(q), float(r)
        shape = (num_envs, *geometry.shape)
        self.mean = np.zeros(shape)
        self.variance = np.full(shape, KALMAN_INITIAL_VARIANCE)

    def reset(
        self,
        env_ids: np.ndarray | list[int],
        ignition: np.ndarray,
        fuel_mask: np.ndarray | None = None,
    ) -> None:
        """Start over: ignition cells (with fuel, if ``fuel_mask`` is given) at
        ``IGNITION_PROBABILITY``, others at 0, every variance ``KALMAN_INITIAL_VARIANCE``,
        every age at the cap."""
        ids = as_ids(env_ids, self.num_envs)
        ignition = np.asarray(ignition, dtype=bool)
        if fuel_mask is not None:
            ignition = ignition & np.asarray(fuel_mask, dtype=bool)
        self.mean[ids] = np.where(ignition, IGNITION_PROBABILITY, 0.0)
        self.variance[ids] = KALMAN_INITIAL_VARIANCE
        self._reset_clock(ids)

    def update(self, env: np.ndarray, cell: np.ndarray, value: np.ndarray) -> None:
        """Apply a batch of reports, z = value, in information form.

        Parameters
        ----------
        env, cell, value : (n,) arrays
            As :meth:`LogOddsBelief.update`. n reports of a cell give
            ``1/P' = 1/P + n/R`` and ``x' = P' (x/P + sum z / R)`` (the sequential scalar
            updates' result), then x is clipped to [0, 1].
        """
        flat, value = self._flat_reports(env, cell, value)
        if flat.size == 0:
            return
        cells, inverse = np.unique(flat, return_inverse=True)
        count = np.bincount(inverse, minlength=cells.size)
        total = np.bincount(inverse, weights=value.astype(np.float64), minlength=cells.size)
        mean, variance = self.mean.reshape(-1), self.variance.reshape(-1)
        information = 1.0 / variance[cells] + count / self.r
        estimate = (mean[cells] / variance[cells] + total / self.r) / information
        mean[cells] = np.clip(estimate, 0.0, 1.0)
        variance[cells] = 1.0 / information

    def predict(self, env_ids: np.ndarray | list[int] | None = None) -> None:
        """Add Q to the variance of every cell (of every or the given environment)."""
        if env_ids is None:
            self.variance += self.q
        else:
            self.variance[as_ids(env_ids, self.num_envs)] += self.q

    def probability(self) -> np.ndarray:
        """The estimate x as the probability of burning, (E, H, W) float64 (a copy)."""
        return self.mean.copy()

    def believed(self) -> np.ndarray:
        """Believed burning (x > 0.5), (E, H, W) bool."""
        return self.mean > 0.5


__all__ = ["KALMAN_INITIAL_VARIANCE", "KALMAN_Q", "KALMAN_R", "KalmanBelief"]
