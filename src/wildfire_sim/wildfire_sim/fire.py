"""Stochastic cellular wildfire model, batched over independent environments.

The model (after Bertsimas et al. and Julian & Kochenderfer; see docs/model.md, Fire) keeps
per cell a fuel amount F >= 0 and a burning flag B. One fire step (2.5 s):

* burning cells consume ``burn_rate`` fuel; a burning cell whose fuel reaches 0 goes out;
* a non-burning cell with fuel ignites with probability
  ``p(s) = 1 - prod_{s'} (1 - P(s, s') B(s'))`` over the 24 cells s' of its 5 x 5
  neighbourhood, ``P(s, s') = min(1, w / (spread_constant * d^2))`` with d^2 the squared
  cell distance and ``w = max(0, 1 + wx*ux + wy*uy)``, (ux, uy) the sign of the direction
  from the source s' to the target s (wx > 0 pushes the fire east).

Implementation notes (why it is fast and reproducible):

* ``log(1 - p) = sum B(s') log(1 - P(s, s'))`` is one 5 x 5 stencil, evaluated for the whole
  batch by a single grouped convolution (one kernel per environment, since wind differs).
* The kernel holds ``round(-log(1 - P) * 2**16)``: integers. Every partial sum is then an
  integer below 2**24, exact in float32 whatever order the convolution sums in, so the
  result is bit-identical for any batch size or convolution algorithm. The quantisation
  changes each P by less than 2e-5 relative (P is capped at 0.99 so the sums stay exact).
* On the paper's 100 x 100 map each environment draws its uniforms from its own generator
  (``seeding.Stream.FIRE``), one per candidate cell (not burning, with fuel, next to fire)
  in row-major order, so a fire depends on its seed only, never on the batch it runs in
  (and every stored score stays what it was).
* With a fuel map (:mod:`wildfire_sim.fuel_map`) each cell draws its initial fuel from its own
  range, and its spread multiplier ``m`` scales its hazard: ``p = 1 - (1 - p0) ** m``, i.e.
  the pressure is multiplied by ``m`` (after the exact integer convolution, so the
  convolution's exactness is kept).
* On any other map the uniform of a candidate is counter-based: a hash of (seed, fire step,
  cell) (:func:`wildfire_sim.seeding.cell_uniforms`). It then depends on nothing but those
  three, so the fire may be stepped on any cut of its active region.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from wildfire_sim.errors import FireConfigError
from wildfire_sim.fuel_map import FuelMap
from wildfire_sim.grid import PAPER_MAP, MapGeometry
from wildfire_sim.ignition import draw_fuel, first_burning
from wildfire_sim.seeding import Stream, cell_uniforms, generator
from wildfire_sim.spread import (
    MAX_SPREAD_PROBABILITY,
    STENCIL_RADIUS,
    FireParams,
    spread_kernel,
    validate_wind,
)

WINDOW_TILE = 32
"""The active window (every burning cell and its 2-cell halo) grows and shrinks in tiles of
this many cells."""
LOG_SCALE = float(2**16)
"""Fixed-point scale of the quantised log-survival kernel."""


def quantised_log_kernel(wind: np.ndarray, spread_constant: float = 22.0) -> np.ndarray:
    """``round(-log(1 - P) * 2**16)`` as float32 integers, shape (..., 5, 5)."""
    probability = np.minimum(spread_kernel(wind, spread_constant), MAX_SPREAD_PROBABILITY)
    return np.rint(-np.log1p(-probability) * LOG_SCALE).astype(np.float32)


class BatchedFire:
    """``num_envs`` independent fires on maps of ``geometry``, stepped together.

    Public state arrays have a leading environment dimension:

    * ``fuel`` (E, H, W) int8, ``initial_fuel`` (E, H, W) int8, ``burning`` (E, H, W) bool;
    * ``wind`` (E, 2) float64; ``steps`` (E,) int64, fire steps taken since ignition.

    Internally the grids are stored environment-last, (H, W, E): that is the channels-last
    layout the batched convolution is fast on, so no transposition is needed on a step;
    the public arrays are transposed views of that storage.

    With ``fuel_map`` (its geometry is the map's) the initial fuel and the spread follow the
    raster (the same for every environment). Environments are (re)started with
    :meth:`reset`; :meth:`step` advances all of them or those selected by a mask, so
    environments of a vectorised trainer may run out of phase.
    """

    def __init__(
        self,
        num_envs: int,
        params: FireParams | None = None,
        geometry: MapGeometry = PAPER_MAP,
        fuel_map: FuelMap | None = None,
    ) -> None:
        if num_envs < 1:
            raise FireConfigError(f"num_envs: expected >= 1, got {num_envs}")
        if fuel_map is not None and fuel_map.geometry != geometry:
            raise FireConfigError(
                f"fuel map: {fuel_map.geometry.text} cells on a {geometry.text} map"
            )
        self.params = (params or FireParams()).validate()
        self.num_envs = num_envs
        self.geometry = geometry
        self.fuel_map = fuel_map
        storage = (*geometry.shape, num_envs)
        self._fuel = np.zeros(storage, dtype=np.int8)
        self._initial_fuel = np.zeros(storage, dtype=np.int8)
        self._burning = np.zeros(storage, dtype=bool)
        self.wind = np.zeros((num_envs, 2), dtype=np.float64)
        self.steps = np.zeros(num_envs, dtype=np.int64)
        self._kernels = np.zeros((num_envs, 1, 5, 5), dtype=np.float32)
        self._generators: list[np.random.Generator | None] = [None] * num_envs
        self._seeds = np.zeros(num_envs, dtype=np.uint64)
        # (row0, row1, col0, col1) of the grid part that can change; None: recompute.
        self._window: tuple[int, int, int, int] | None = None

    @property
    def burning(self) -> np.ndarray:
        """Burning flags, (E, H, W) bool (a view of the environment-last storage)."""
        return self._burning.transpose(2, 0, 1)

    @property
    def fuel(self) -> np.ndarray:
        """Fuel left, (E, H, W) int8 (a view)."""
        return self._fuel.transpose(2, 0, 1)

    @property
    def initial_fuel(self) -> np.ndarray:
        """Fuel at ignition, (E, H, W) int8 (a view)."""
        return self._initial_fuel.transpose(2, 0, 1)

    def reset(
        self,
        env_ids: np.ndarray | list[int],
        seeds: np.ndarray | list[int],
        ignition: np.ndarray,
        fuel_mask: np.ndarray,
        wind: np.ndarray,
    ) -> None:
        """Restart the fires of ``env_ids`` from ignition.

        ``ignition`` and ``fuel_mask`` are boolean (H, W) masks shared by all, or (k, H, W)
        one per environment; ``wind`` is (2,) or (k, 2). Initial fuel is drawn uniformly from
        the integers [fuel_min, fuel_max] (0 outside ``fuel_mask``) with the environment's
        own generator (from the fuel map's per-cell range, with one); ignition cells without
        fuel do not burn.
        """
        env_ids = np.atleast_1d(np.asarray(env_ids, dtype=np.int64))
        seeds = np.atleast_1d(np.asarray(seeds, dtype=np.int64))
        if env_ids.shape != seeds.shape:
            raise FireConfigError(f"got {env_ids.size} environments but {seeds.size} seeds")
        grid = self.geometry.shape
        ignition = np.broadcast_to(np.asarray(ignition, dtype=bool), (env_ids.size, *grid))
        fuel_mask = np.broadcast_to(np.asarray(fuel_mask, dtype=bool), (env_ids.size, *grid))
        wind = np.broadcast_to(validate_wind(wind), (env_ids.size, 2))
        p = self.params
        for k, (env, seed) in enumerate(zip(env_ids.tolist(), seeds.tolist(), strict=True)):
            rng = generator(seed, Stream.FIRE)
            fuel = draw_fuel(rng, grid, fuel_mask[k], p, self.fuel_map)
            self._fuel[:, :, env] = fuel
            self._initial_fuel[:, :, env] = fuel
            self._burning[:, :, env] = first_burning(ignition[k], fuel)
            self._generators[env] = rng
        self.wind[env_ids] = wind
        self._seeds[env_ids] = seeds.astype(np.uint64)
        self.steps[env_ids] = 0
        self._window = None
        self._kernels[env_ids, 0] = quantised_log_kernel(wind, p.spread_constant)

    def ignition_pressure(self, window: tuple[slice, slice] | None = None) -> np.ndarray:
        """Quantised ``-log(1 - p) * 2**16`` per cell, (H, W, E) float32 (exact integers).

        With ``window`` (rows, cols), only that part of the grid is evaluated; it must hold
        every burning cell with a margin of ``STENCIL_RADIUS`` (beyond it the pressure is 0).
        """
        rows, cols = window or (slice(None), slice(None))
        burning = torch.from_numpy(self._burning[rows, cols].astype(np.float32))
        # (h, w, E) memory seen as (1, E, h, w) is channels-last, the layout oneDNN's
        # depthwise kernel is fastest on; its output comes back in the same layout. (The
        # reshape gives the batch dimension its proper stride: with a stride-E batch
        # dimension, torch would copy the input first.)
        pressure = F.conv2d(
            burning.reshape(1, *burning.shape).permute(0, 3, 1, 2),
            torch.from_numpy(self._kernels).contiguous(memory_format=torch.channels_last),
            padding=STENCIL_RADIUS,
            groups=self.num_envs,
        )
        return pressure[0].permute(1, 2, 0).numpy()

    def step(self, mask: np.ndarray | None = None) -> None:
        """Advance every environment (or those where ``mask`` is True) by one fire step."""
        stepped = np.ones(self.num_envs, dtype=bool) if mask is None else np.asarray(mask, bool)
        if not stepped.any():
            return
        # Only the window around the fires changes; early in an episode it is a small part
        # of the map, so everything below works on views of it.
        window = self._active_window()
        if window[0].start == window[0].stop:
            # Every fire of the batch is out: nothing burns, nothing can ignite.
            self.steps += stepped
            return
        pressure = self.ignition_pressure(window)
        burning, fuel = self._burning[window], self._fuel[window]
        # Cells that may ignite: not burning, fuel left, some burning neighbour.
        candidates = ~burning & (fuel > 0) & (pressure > 0)
        if mask is not None:
            candidates &= stepped
        flat_index = np.flatnonzero(candidates)
        ignites = np.zeros(burning.shape, dtype=bool)
        if flat_index.size:
            uniforms = self._draw_uniforms(flat_index, window)
            hazard = pressure.ravel()[flat_index].astype(np.float64)
            if self.fuel_map is not None and self.fuel_map.spread is not None:
                # Storage is (h, w, E): the candidate's cell of the window is index // E.
                hazard *= self.fuel_map.spread[window].ravel()[flat_index // self.num_envs]
            probability = -np.expm1(-hazard / LOG_SCALE)
            ignites.ravel()[flat_index] = uniforms < probability
        # Burning cells always hold fuel, so fuel - burn_rate only needs clipping above 1.
        consumed = burning if mask is None else burning & stepped
        fuel -= consumed.view(np.int8) * np.int8(self.params.burn_rate)
        if self.params.burn_rate > 1:
            np.maximum(fuel, 0, out=fuel)
        burning &= fuel > 0
        burning |= ignites
        self.steps += stepped
        self._shrink_window()

    def _draw_uniforms(self, flat_index: np.ndarray, window: tuple[slice, slice]) -> np.ndarray:
        """One uniform per candidate, given by its index into the window's (h, w, E) storage."""
        env = flat_index % self.num_envs
        if self.geometry.is_paper:
            return self._generator_uniforms(env)
        # Counter-based: the candidate's map cell and the fire step it is drawn for.
        width = window[1].stop - window[1].start
        cell = flat_index // self.num_envs
        row, col = cell // width + window[0].start, cell % width + window[1].start
        return cell_uniforms(self._seeds[env], self.steps[env], row * self.geometry.cols + col)

    def _generator_uniforms(self, env_of_candidate: np.ndarray) -> np.ndarray:
        """One uniform per candidate cell, each from its environment's own generator.

        Each environment draws as many numbers as it has candidates, in row-major cell order,
        which depends on its own fire only, never on the batch (nor on the window, which
        only leaves out cells that cannot be candidates).
        """
        # Candidates arrive cell-major; a stable sort by environment (radix sort on uint16)
        # groups each environment's cells, still in row-major order.
        order = np.argsort(env_of_candidate.astype(np.uint16), kind="stable")
        counts = np.bincount(env_of_candidate, minlength=self.num_envs)
        grouped = np.empty(env_of_candidate.size, dtype=np.float64)
        start = 0
        for env in np.flatnonzero(counts).tolist():
            rng = self._generators[env]
            if rng is None:
                raise RuntimeError(f"environment {env} stepped before reset")
            stop = start + int(counts[env])
            rng.random(out=grouped[start:stop])
            start = stop
        uniforms = np.empty_like(grouped)
        uniforms[order] = grouped
        return uniforms

    def _active_window(self) -> tuple[slice, slice]:
        """Rows and columns holding every burning cell with a stencil margin (all envs)."""
        if self._window is None:
            self._window = self._burning_bounds(0, self.geometry.rows, 0, self.geometry.cols)
        r0, r1, c0, c1 = self._window
        return slice(r0, r1), slice(c0, c1)

    def _burning_bounds(self, r0: int, r1: int, c0: int, c1: int) -> tuple[int, int, int, int]:
        """Bounding box of the burning cells inside rows r0:r1, columns c0:c1, plus margin,
        in whole tiles of the map."""
        part = self._burning[r0:r1, c0:c1]
        rows = np.flatnonzero(part.any(axis=(1, 2)))
        if rows.size == 0:
            return (0, 0, 0, 0)
        cols = np.flatnonzero(part.any(axis=(0, 2)))
        m, t = STENCIL_RADIUS, WINDOW_TILE
        # Snapped out to whole tiles: the window then keeps its size for many steps, and
        # torch reuses its convolution for that size (a new size costs ~10x a step).
        return (
            max((r0 + int(rows[0]) - m) // t * t, 0),
            min(-(-(r0 + int(rows[-1]) + 1 + m) // t) * t, self.geometry.rows),
            max((c0 + int(cols[0]) - m) // t * t, 0),
            min(-(-(c0 + int(cols[-1]) + 1 + m) // t) * t, self.geometry.cols),
        )

    def _shrink_window(self) -> None:
        """After a step, fit the window to the burning cells again (fires burn out too)."""
        if self._window is not None:
            self._window = self._burning_bounds(*self._window)

    def affected(self) -> np.ndarray:
        """Cells burning or with less fuel than they started with, (E, H, W) bool."""
        return self.burning | (self.fuel < self.initial_fuel)


__all__ = [
    "MAX_SPREAD_PROBABILITY",
    "STENCIL_RADIUS",
    "BatchedFire",
    "FireParams",
    "quantised_log_kernel",
    "spread_kernel",
    "validate_wind",
]
