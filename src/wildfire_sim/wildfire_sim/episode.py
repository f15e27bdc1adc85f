"""The episode rule book, and one fire episode as the fire-simulator node runs it (no ROS).

Every episode — :class:`FireEpisode` here (the fire-simulator node), the training
environment ``wildfire_world.env.WildfireVecEnv`` and the transitions rebuilt from bags
(``wildfire_learning.bag_transitions``) — follows these rules, written only here:

* the fire starts as its landscape says (:meth:`wildfire_sim.landscape.Landscape.start`) and
  pre-burns (:func:`preburn`): ``preburn_steps`` fire steps, or with ``preburn_area_m2`` until
  the fire has touched that area (so a field episode starts on a fire of realistic size);
* each decision increments the counter and every ``DECISIONS_PER_FIRE_STEP``-th decision
  steps the fire;
* after a fire step (and after the pre-burn) the episode is *terminated* when a burning cell
  lies within ``border_cells`` of the map edge (:func:`fire_at_border`), otherwise it is
  *truncated* once the decisions of the duration (:func:`decisions_in`) are flown.

:data:`EPISODE_DEFAULTS` holds the default scenario, under the names of the fire
simulator's parameters (``config/wildfire.yaml`` is tested to agree with it).
"""

from __future__ import annotations

from enum import StrEnum
from typing import TYPE_CHECKING

import numpy as np

# A tick's stamp is the wire's: every node and message shares one decision clock.
from wildfire_msgs_py.contract import DECISION_PERIOD_NS
from wildfire_msgs_py.map_geometry import CELL_SIZE_M
from wildfire_sim.defaults import EPISODE_DEFAULTS, EpisodeDefaults
from wildfire_sim.grid import PAPER_MAP, MapGeometry
from wildfire_sim.landscape import PAPER_LANDSCAPE, Landscape
from wildfire_sim.shapes import Shape, shape_masks

if TYPE_CHECKING:
    # The fire model runs on torch: only the code that steps a fire loads it, so nodes that
    # need just these rules (agents, the aggregator) start without importing torch.
    from wildfire_sim.fire import BatchedFire, FireParams

DECISIONS_PER_FIRE_STEP = 25
"""2.5 s fire steps at 10 Hz decisions."""
NS_PER_S = 1_000_000_000
FIRE_STEP_NS = DECISIONS_PER_FIRE_STEP * DECISION_PERIOD_NS
"""A fire step in nanoseconds (the stamps of successive fire maps)."""
AHEAD_TICKS = 2 * DECISIONS_PER_FIRE_STEP
"""Lockstep: how far past the announced tick an honest input can be stamped (fire maps run
one fire step ahead at most; statuses, states, visits and beliefs a tick or two). Every
node refuses anything further, so a forged far-future stamp cannot hold an inbox slot."""
REALTIME_AHEAD_NS = 10 * NS_PER_S
"""Real time: stamps more than 10 s past the node clock are refused (clock skew allowance)."""


class Mode(StrEnum):
    """How an episode is paced (every node's ``mode`` parameter, converted once)."""

    LOCKSTEP = "lockstep"
    """Message driven on sim time: each tick waits for every node; equals the environment."""
    REALTIME = "realtime"
    """Wall-clock timers; stamps are the node clock and late decisions miss their slot."""


MODES = tuple(mode.value for mode in Mode)


def decisions_in(duration_s: float) -> int:
    """Decisions flown in ``duration_s`` seconds (the truncation limit)."""
    # An integer rate (10 Hz): durations given to 0.1 s give whole decisions exactly.
    return round(duration_s * (NS_PER_S // DECISION_PERIOD_NS))


def fire_at_border(burning: np.ndarray, border_cells: int) -> np.ndarray:
    """Whether a burning cell lies within ``border_cells`` of the map edge, per grid.

    ``burning`` is (..., H, W) bool — one grid or a batch with leading environment
    dimensions; the answer is a bool array of the leading shape (0-d for one grid).
    """
    height, width = burning.shape[-2:]
    band = np.ones((height, width), dtype=bool)
    band[border_cells : height - border_cells, border_cells : width - border_cells] = False
    return np.asarray((burning & band).any(axis=(-2, -1)))


def fire_step_tick(tick: int) -> int:
    """Decision index of the fire step whose map holds at decision ``tick``."""
    return (tick // DECISIONS_PER_FIRE_STEP) * DECISIONS_PER_FIRE_STEP


def stamp_ceiling_ns(status_tick: int) -> int:
    """Lockstep: the newest stamp an honest input can carry once tick ``status_tick`` (-1:
    none yet) is announced."""
    return (max(status_tick, 0) + AHEAD_TICKS) * DECISION_PERIOD_NS


MAX_PREBURN_STEPS = 4000
"""A pre-burn to an area stops after this many fire steps (2.8 h) even if it is not reached."""


def preburn(
    fire: BatchedFire,
    envs: np.ndarray,
    steps: int,
    area_m2: float = 0.0,
    border_cells: int = EPISODE_DEFAULTS.border_cells,
) -> None:
    """Pre-burn the fires of ``envs`` ((E,) bool): ``steps`` fire steps, or with
    ``area_m2 > 0`` until each has touched that area (burning or burnt cells), gone out,
    reached the border band or burnt :data:`MAX_PREBURN_STEPS` steps."""
    if area_m2 <= 0:
        for _ in range(steps):
            fire.step(envs)
        return
    cells = area_m2 / (CELL_SIZE_M * CELL_SIZE_M)
    active = np.asarray(envs, dtype=bool).copy()
    for _ in range(MAX_PREBURN_STEPS):
        burning = fire.burning
        active &= (fire.affected().sum(axis=(1, 2)) < cells) & burning.any(axis=(1, 2))
        active &= ~fire_at_border(burning, border_cells)
        if not active.any():
            return
        fire.step(active)


def initial_fire(
    seed: int,
    shape: Shape | str,
    wind: tuple[float, float] = (0.0, 0.0),
    geometry: MapGeometry = PAPER_MAP,
) -> BatchedFire:
    """The fire of episode ``seed`` at ignition (before the pre-burn), one environment."""
    from wildfire_sim.fire import BatchedFire

    masks = shape_masks(
        Shape.parse(str(shape.value if isinstance(shape, Shape) else shape)), geometry
    )
    fire = BatchedFire(1, geometry=geometry)
    fire.reset([0], [seed], masks.ignition, masks.fuel, np.asarray(wind, dtype=np.float64))
    return fire


class FireEpisode:
    """A seeded fire stepped by decisions, with the episode-end rules of the environment."""

    def __init__(
        self,
        seed: int,
        shape: Shape | str,
        wind: tuple[float, float],
        *,
        max_decisions: int,
        preburn_steps: int = EPISODE_DEFAULTS.preburn_steps,
        border_cells: int = EPISODE_DEFAULTS.border_cells,
        params: FireParams | None = None,
        ground: Landscape = PAPER_LANDSCAPE,
        preburn_area_m2: float = 0.0,
    ) -> None:
        self.seed = int(seed)
        self.shape = Shape.parse(str(shape.value if isinstance(shape, Shape) else shape))
        self.wind = (float(wind[0]), float(wind[1]))
        self.max_decisions = int(max_decisions)
        self.border_cells = int(border_cells)
        masks = ground.start(self.shape, self.seed, self.border_cells)
        from wildfire_sim.fire import BatchedFire

        self.fire = BatchedFire(1, params, ground.geometry, ground.fuel)
        self.fire.reset([0], [self.seed], masks.ignition, masks.fuel, np.asarray(self.wind))
        self.ignition_burning = self.fire.burning[0].copy()
        preburn(self.fire, np.ones(1, dtype=bool), preburn_steps, preburn_area_m2, border_cells)
        self.decisions = 0
        self.phase = "running"
        if fire_at_border(self.burning, self.border_cells):
            self.phase = "terminated"

    @property
    def burning(self) -> np.ndarray:
        """(H, W) bool truth."""
        return self.fire.burning[0]

    @property
    def fuel(self) -> np.ndarray:
        """(H, W) int8 fuel left."""
        return self.fire.fuel[0]

    @property
    def final(self) -> bool:
        return self.phase != "running"

    def advance(self) -> bool:
        """One decision; True when the fire stepped. Updates :attr:`phase`."""
        if self.final:
            raise RuntimeError("the episode has ended")
        self.decisions += 1
        stepped = self.decisions % DECISIONS_PER_FIRE_STEP == 0
        if stepped:
            self.fire.step()
            if fire_at_border(self.burning, self.border_cells):
                self.phase = "terminated"
        if self.phase == "running" and self.decisions >= self.max_decisions:
            self.phase = "truncated"
        return stepped


__all__ = [
    "AHEAD_TICKS",
    "DECISIONS_PER_FIRE_STEP",
    "DECISION_PERIOD_NS",
    "EPISODE_DEFAULTS",
    "FIRE_STEP_NS",
    "MAX_PREBURN_STEPS",
    "MODES",
    "NS_PER_S",
    "REALTIME_AHEAD_NS",
    "EpisodeDefaults",
    "FireEpisode",
    "Mode",
    "decisions_in",
    "fire_at_border",
    "fire_step_tick",
    "initial_fire",
    "preburn",
    "stamp_ceiling_ns",
]
