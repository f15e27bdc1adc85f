"""A particle filter over the wind: K fire models, weighted by the reports, resampled.

The wind (wx, wy) of an episode is fixed but unknown to the team. A fire model run with
the right wind predicts where the front goes between reports, whereas the process term of
:class:`wildfire_belief.filtered_belief.LogOddsBelief` spreads alike in every direction
without one. This filter estimates the wind from the reports themselves.

Particles
---------
K (40) fire models, each with its own wind, drawn uniformly in
``[-max_wind, max_wind]^2`` (the scenario's range) at :meth:`WindFilter.reset`. A particle
is the fire model *in mean field*: a probability of burning per cell, moved at each fire
step by the fire model's stencil (:func:`wildfire_sim.fire.spread_kernel`) for its wind
and by the fuel model's burn-out, and updated by every report by exact Bayes. That is
exactly a :class:`LogOddsBelief`, so the K particles are the K environments of one
``LogOddsBelief``: one batched process step moves them all, each with its own kernel. All
start from the team's belief at the start (the ignition seed) and may pre-burn
unobserved, each with its wind, as the real fire did before the aircraft came.

Weights
-------
The reports are independent flips (known p) of the true per-cell values, so given
particle k's probability b_k of a cell before a batch of its reports (n1 "burning", n0
"not"), their likelihood is ``b_k (1 - p)^n1 p^n0 + (1 - b_k) p^n1 (1 - p)^n0``. Taken
batch by batch, each before that batch's Bayes update, these multiply out to the
particle's marginal likelihood of all the reports (the predictive decomposition), so
:meth:`WindFilter.observe` adds ``log(1 + e^(L + d)) - log(1 + e^L)`` per reported cell
to the particle's log-weight (L its log-odds, ``d = (n1 - n0) log((1 - p) / p)``; the
factor common to all particles is dropped).

Why mean-field particles, not sampled fires
-------------------------------------------
Filters whose particles are sampled fires (the K environments of a
:class:`wildfire_sim.fire.BatchedFire`) were tried first and do not identify the wind:

* bootstrap (each fire stepped with its own random numbers, weights from the per-report
  Bernoulli likelihood of its sampled map): a camera band gives thousands of reports per
  fire step, so the weights collapse every step onto the particle whose random ignitions
  happened to match, whatever its wind; on a synthetic fire with wind (0.6, 0) the
  estimates after 20 fire steps ranged from (0.02, -0.56) to (0.52, 0.68) over seeds;
* fully adapted (each cell's next state drawn from its posterior given the step's
  reports, weights from the fire's exact transition likelihood): a sampled fire that once
  draws a wrong ignition (a posterior tail, over hundreds of front cells) keeps a burning
  cell that the reports deny for 15 to 20 fire steps, and those few errors outweigh the
  wind's evidence: with the winds fixed on a grid, the log-likelihoods spread over
  hundreds of units in no order of the wind.

Yet the fire's exact transition likelihood given the true states ranks the winds, by 10
to 50 log-units over 20 steps, with its maximum near the true wind: the information is
there, for a filter whose particles cannot commit to a wrong state. A mean-field particle
does not: its probabilities follow the reports, and a contradiction costs it at most the
log-odds bound once. With all cells reported, its log-likelihood over a grid of winds
peaks where the exact one does (six fires out of six).

Resampling
----------
Systematic (one uniform of the generator passed in), at a fire step, when the effective
sample size has fallen under half of K. A child copies its parent's belief (log-odds,
burnt-out split, burn ages) and takes the parent's wind plus a Gaussian jitter
(``jitter``, 0.05, clipped to the range): the wind has no dynamics of its own, so
without the jitter the resampled particles would collapse onto a few winds for ever.

Outputs
-------
:meth:`WindFilter.probability` is the weighted mean of the particles' probabilities of
burning: itself a belief, a mixture over winds. :meth:`WindFilter.wind_estimate` is the
weighted mean of the winds. The generator passed in is the filter's only source of
randomness (initial winds, resampling, jitter), so a filter is bit-reproducible for a
given generator state and sequence of calls.

Where it pays (the measurement of :mod:`wildfire_belief.filtered_belief`: 2 x 10
synthetic episodes, a 150 m sensor circling the fire, p = 0.1, last 100 s): the wind
estimate ends 0.18 and 0.14 from the true wind on average (a zero-wind guess: 0.58 and
0.60). Against the log-odds belief without wind (IoU 0.63 and 0.62, 226 and 215 false
alarms, Brier 28.1e-3 and 28.0e-3):

* the log-odds belief with the filter's estimate as its wind (``set_wind`` each fire
  step): IoU +0.04 (better in 19 of 20 episodes), false alarms -46 and -38, Brier -4.5e-3
  and -4.2e-3;
* the filter's own mixture: IoU +0.06 and +0.07 (0.69 both; better in 19 of 20), false
  alarms -71 and -67, Brier -6.6e-3 and -6.9e-3;
* for scale, the true wind in the log-odds belief: IoU 0.70 both, false alarms 148 and
  143, Brier 20.9e-3 and 20.6e-3.

So the mixture is the team's best belief when the wind is unknown, within 0.01 IoU of
knowing the wind.

Cost (measured on the project's 2-core development machine, shared, load average 2 to
3.5, 40 particles): a fire step about 45 to 50 ms, almost all of it the process step of
the 40 maps (resampling ~1.3 ms), i.e. ~2 ms per decision amortised over the 25 decisions
of a fire step; an :meth:`WindFilter.observe` of ~700 reports 0.6 to 0.8 ms;
:meth:`WindFilter.probability` ~1.4 ms. About 3 ms per decision for one team: cheap next
to a 100 ms decision, but 40 belief process steps per fire step, so a vectorised trainer
pays it for every environment.
"""

from __future__ import annotations

import math

import numpy as np

from wildfire_belief.filtered_belief import PIXEL_ERROR, LogOddsBelief
from wildfire_sim.defaults import EPISODE_DEFAULTS
from wildfire_sim.grid import PAPER_MAP, MapGeometry, geometry_of
from wildfire_sim.seeding import Stream, generator
from wildfire_sim.spread import FireParams

NUM_PARTICLES = 40
"""Default number of particles (fire models)."""
WIND_JITTER = 0.05
"""Standard deviation of the Gaussian jitter added to a resampled particle's wind."""
RESAMPLE_THRESHOLD = 0.5
"""Resample when the effective sample size falls under this fraction of the particles."""


class WindFilter:
    """Particle filter over the wind of one team episode (see the module notes).

    Parameters
    ----------
    num_particles : int
        K, the number of fire models.
    rng : numpy.random.Generator
        The filter's only source of randomness; the caller owns it.
    p : float
        Report flip probability, in (0, 0.5).
    max_wind : float
        Bound of each wind component (the scenario's ``max_wind``), in (0, 1].
    jitter : float
        Standard deviation of the wind jitter after resampling.
    params : FireParams, optional
        Parameters of the particles' fire model; the defaults if omitted.
    geometry : MapGeometry
        The map (rows and columns of cells).

    Attributes
    ----------
    particles : LogOddsBelief
        The particles, one environment each: ``particles.wind`` (K, 2) their winds,
        ``particles.log_odds`` (K, H, W) their beliefs.
    log_weights : (K,) float64
        Unnormalised log-weights (their maximum is kept at 0).
    """

    def __init__(
        self,
        num_particles: int,
        rng: np.random.Generator,
        p: float = PIXEL_ERROR,
        *,
        max_wind: float = EPISODE_DEFAULTS.max_wind,
        jitter: float = WIND_JITTER,
        params: FireParams | None = None,
        geometry: MapGeometry = PAPER_MAP,
    ) -> None:
        if num_particles < 1:
            raise ValueError(f"num_particles: expected >= 1, got {num_particles}")
        if not 0.0 < p < 0.5:
            raise ValueError(f"p: expected 0 < p < 0.5, got {p}")
        if not 0.0 < max_wind <= 1.0 or not jitter >= 0.0:
            raise ValueError(
                f"max_wind, jitter: expected (0, 1] and >= 0, got {max_wind}, {jitter}"
            )
        self.num_particles = num_particles
        self.rng = rng
        self.max_wind = float(max_wind)
        self.jitter = float(jitter)
        self.geometry = geometry
        self.report_log_odds = math.log((1.0 - p) / p)
        self.particles = LogOddsBelief(num_particles, p, geometry=geometry, params=params)
        self.log_weights = np.zeros(num_particles)

    def reset(
        self, ignition: np.ndarray, fuel_mask: np.ndarray | None = None, preburn_steps: int = 0
    ) -> None:
        """Start every particle from ``ignition`` with a wind drawn in the range.

        Parameters
        ----------
        ignition : (H, W) bool
            Cells believed burning at the start: the team's belief.
        fuel_mask : (H, W) bool, optional
            Cells that may hold fuel; all if omitted.
        preburn_steps : int
            Fire steps each particle runs at once, unobserved, with its own wind (e.g. the
            episode's pre-burn when ``ignition`` is the seed: the team knows the rules).
        """
        ids = np.arange(self.num_particles)
        winds = self.rng.uniform(-self.max_wind, self.max_wind, size=(self.num_particles, 2))
        self.particles.reset(ids, ignition, fuel_mask)
        self.particles.set_wind(ids, winds)
        for _ in range(preburn_steps):
            self.particles.predict()
        self.log_weights = np.zeros(self.num_particles)

    def weights(self) -> np.ndarray:
        """Normalised particle weights, (K,) float64."""
        shifted = np.exp(self.log_weights - self.log_weights.max())
        return shifted / shifted.sum()

    def effective_sample_size(self) -> float:
        """``1 / sum w^2`` of the normalised weights, in [1, K]."""
        return float(1.0 / np.square(self.weights()).sum())

    def observe(self, cells: np.ndarray, values: np.ndarray) -> None:
        """Weight the particles by a batch of reports, then update each by Bayes.

        Parameters
        ----------
        cells : (n,) int
            Flat cell index ``row * cols + col`` of each report (repeats allowed).
        values : (n,) bool
            Reported burning value of each.
        """
        cells = np.asarray(cells, dtype=np.int64).reshape(-1)
        values = np.asarray(values, dtype=bool).reshape(-1)
        if cells.size != values.size:
            raise ValueError(f"got {cells.size} cells but {values.size} values")
        if cells.size == 0:
            return
        if cells.min() < 0 or cells.max() >= self.geometry.cells:
            raise ValueError("a report names a cell outside the map")
        touched, inverse = np.unique(cells, return_inverse=True)
        net = np.bincount(inverse, weights=np.where(values, 1.0, -1.0), minlength=touched.size)
        shift = net * self.report_log_odds
        log_odds = self.particles.log_odds.reshape(self.num_particles, -1)
        before = log_odds[:, touched]
        # log(b e^d + 1 - b) with b = sigmoid(L): log(1 + e^(L + d)) - log(1 + e^L).
        gain = np.logaddexp(0.0, before + shift) - np.logaddexp(0.0, before)
        self.log_weights += gain.sum(axis=1)
        self.log_weights -= self.log_weights.max()
        bound = self.particles.max_log_odds
        log_odds[:, touched] = np.clip(before + shift, -bound, bound)

    def step(self) -> None:
        """One fire step: resample if the weights have degenerated, then every particle's
        process step."""
        if self.effective_sample_size() < RESAMPLE_THRESHOLD * self.num_particles:
            self.resample()
        self.particles.predict()

    def resample(self) -> None:
        """Systematic resampling: children copy their parent's belief and take its wind plus
        a jitter; the weights become uniform."""
        k, particles = self.num_particles, self.particles
        positions = (self.rng.random() + np.arange(k)) / k
        parents = np.minimum(np.searchsorted(np.cumsum(self.weights()), positions), k - 1)
        winds = particles.wind[parents] + self.rng.normal(0.0, self.jitter, size=(k, 2))
        particles.log_odds[...] = particles.log_odds[parents]
        particles.spent[...] = particles.spent[parents]
        particles.burn_age[...] = particles.burn_age[parents]
        particles.set_wind(np.arange(k), np.clip(winds, -self.max_wind, self.max_wind))
        self.log_weights = np.zeros(k)

    def probability(self) -> np.ndarray:
        """Weighted mean of the particles' probabilities of burning, (H, W) float64."""
        probability = self.particles.probability().reshape(self.num_particles, -1)
        return (self.weights() @ probability).reshape(self.geometry.shape)

    def wind_estimate(self) -> np.ndarray:
        """Weighted mean of the particles' winds, (2,) float64."""
        return self.weights() @ self.particles.wind

    def steer(self, belief: LogOddsBelief, env: int) -> None:
        """A fire step of the filter, then its estimate into ``belief``'s process term for
        environment ``env`` (call it before the belief's own ``predict``). The environment
        and the belief aggregator both step their filters so, in this order."""
        self.step()
        belief.set_wind([env], self.wind_estimate())


def team_wind_filter(
    seed: int, p: float, ignition: np.ndarray, fuel_mask: np.ndarray, preburn_steps: int
) -> WindFilter:
    """The wind filter of episode ``seed``'s team: ``NUM_PARTICLES`` fire models drawn from
    the episode's own stream (``Stream.WIND``), started from its ignition seed over the
    pre-burn. The environment and the belief aggregator start theirs here alike."""
    rng = generator(seed, Stream.WIND)
    particles = WindFilter(NUM_PARTICLES, rng, p, geometry=geometry_of(ignition))
    particles.reset(ignition, fuel_mask, preburn_steps)
    return particles


__all__ = [
    "NUM_PARTICLES",
    "RESAMPLE_THRESHOLD",
    "WIND_JITTER",
    "WindFilter",
    "team_wind_filter",
]
