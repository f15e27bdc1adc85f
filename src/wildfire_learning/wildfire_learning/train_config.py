"""What a training run is given and what it counts, below the code that trains.

:class:`TrainConfig` holds the hyperparameters (every field is a ``wildfire train`` option,
its help in the field's metadata), :class:`RunOptions` where and how a run writes its files,
:class:`TrainState` the counters a checkpoint saves, and :func:`replay_shapes` the shapes of
a replay frame. The training loop (``dqn.py``) and its parts (``checkpoint.py``,
``experience.py``, ``train_status.py``, ``validation.py``, ``model_card.py``) import them from
here, and this module imports none of those, so the imports point one way.

The config of a resumed run is one merge, :func:`resolve_config`: the defaults, under the
config its checkpoint saved, under the values given explicitly (``wildfire train``'s options
or a library caller's). Old checkpoints keep training the way they started: a saved config
that predates a hyperparameter reads it as the value that reproduces the old behaviour
(:data:`PRE_EXTENSION_VALUES`), not as today's default.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from torch import nn

from wildfire_agent.approaches import APPROACHES, IMAGE_SHAPES, image_shape
from wildfire_agent.pairwise import STATE_SIZE, peer_count
from wildfire_agent.policy_names import ORACLE_POLICY, PLANNER_POLICIES
from wildfire_belief.radio import CommError, CommModel
from wildfire_learning.architectures import ARCHITECTURES, build_q_network, network_name
from wildfire_learning.errors import LearningError
from wildfire_learning.evaluate import VALIDATION_SEED_BASE
from wildfire_msgs_py.map_geometry import PAPER_MAP, MapGeometry, MapGeometryError
from wildfire_sim.episode import EPISODE_DEFAULTS
from wildfire_sim.landscape import read_landscape
from wildfire_world.env import EnvConfig

EVAL_SEED_BASE = VALIDATION_SEED_BASE
"""Evaluation seeds during training start here; training seeds stay below."""
TEACHERS = ("none", *PLANNER_POLICIES, ORACLE_POLICY)
"""Values of ``--teacher``: no teacher, or a planner that labels states (a receding-horizon
baseline, or the clairvoyant ``oracle``)."""
REWARDS = ("approach", *APPROACHES)
"""Values of ``--reward``: the approach's own reward, or either approach's by name (the
observation network trained on the team reward, for one)."""
PRE_EXTENSION_VALUES: dict[str, Any] = {
    "n_step": 1,
    "reward_scale": 1.0,
    "explore_hold": 1,
    "double_q": False,
}
"""Values of fields added after the first runs, for configs saved before them: a resumed run
keeps training the way it started (one-step, unscaled, plain epsilon-greedy, single Q)."""


def linear_schedule(start: float, end: float, duration: int, t: int) -> float:
    """Linear from ``start`` at ``t = 0`` to ``end`` at ``t = duration``, then ``end`` (falling
    like epsilon, or rising like prioritised replay's beta)."""
    if duration <= 0:
        return end
    value = (end - start) / duration * t + start
    return max(value, end) if end <= start else min(value, end)


def hyperparameter(default: Any, help: str, **option: Any) -> Any:
    """A :class:`TrainConfig` field: its default and the help of its ``wildfire train`` option.

    ``option`` may hold ``name`` (the option's name when not the field's), ``choices``,
    ``min`` (integers: the smallest valid value, checked by :meth:`TrainConfig.validate`) and
    ``unit`` (floats: True for a value in [0, 1]; other floats must be > 0 on the command line).
    """
    return field(default=default, metadata={"help": help, **option})


@dataclass
class TrainConfig:
    """Hyperparameters of a training run (every field is a ``wildfire train`` option)."""

    approach: str = hyperparameter(
        "obs",
        "``obs`` (sensor image, observation-based reward) or ``belief`` (ego belief, team reward).",
        choices=APPROACHES,
    )
    reward: str = hyperparameter(
        "approach",
        "Training reward: the approach's own (``approach``), or ``obs`` (observation-based) / "
        "``belief`` (team reward - proximity) whatever the network sees.",
        choices=REWARDS,
    )
    arch: str = hyperparameter(
        "paper",
        "Network: ``paper`` (the paper's); belief only: ``fast`` / ``lite`` (input average-pooled "
        "to 50x50 / 25x25).",
        choices=ARCHITECTURES,
    )
    seed: int = hyperparameter(
        1,
        "Seed of network initialisation, exploration, replay sampling and training episodes.",
        min=0,
    )
    total_samples: int = hyperparameter(
        2_835_000,
        "Stop after this many aircraft decisions (prefill + 280 000 iterations x 10).",
        min=0,
    )
    iterations: int = hyperparameter(
        0, "If > 0: stop after this many training iterations instead of ``total_samples``.", min=0
    )
    num_envs: int = hyperparameter(16, "Episodes stepped together.", min=1)
    n_aircraft: int = hyperparameter(2, "Aircraft per training episode.", min=1)
    shapes: tuple[str, ...] = hyperparameter(
        ("circular", "arc"),
        "Fire shapes of training episodes, drawn uniformly (closed and open fronts mixed).",
    )
    max_wind: float = hyperparameter(
        EPISODE_DEFAULTS.max_wind,
        "Each wind component is uniform in [-max_wind, max_wind] (random wind).",
        unit=True,
    )
    comm: str = hyperparameter(
        "ideal",
        "Radio links: ``ideal`` (one shared belief), ``none`` or ``range=R[,loss=P][,delay=D]`` "
        "(each aircraft observes its own belief replica and heard peers).",
        comm=True,
    )
    sensor: str = hyperparameter(
        "disc",
        "``disc`` (the paper's perfect 100 m sensor) or ``camera`` (four cameras, noisy: a "
        "filtered belief).",
        choices=("disc", "camera"),
    )
    pixel_error: float = hyperparameter(
        0.0, "Probability that a report flips (0.1 is the camera's usual).", pixel_error=True
    )
    wind_filter: bool = hyperparameter(
        False, "Under noisy sensing, estimate the wind for the belief's process term."
    )
    map_size: str = hyperparameter(
        PAPER_MAP.text,
        "Rows and columns of 10 m cells (``R,C``, each in [50, 2000]; a fuel map's extent "
        "when one is given and this is left at the default).",
        map_size=True,
    )
    fuel_map: str = hyperparameter(
        "",
        "Fuel raster (GeoTIFF or .npy, stored as an absolute path; empty: the paper's fuel).",
        path=True,
    )
    fuel_classes: str = hyperparameter(
        "", "The fuel map holds land-cover classes: ``corine``, ``fbfm13`` or a YAML table."
    )
    ignition_map: str = hyperparameter(
        "",
        "Cells burning at the start, from a raster (empty: the shape or --ignitions).",
        path=True,
    )
    ignitions: int = hyperparameter(
        0, "Seeded 5 x 5 ignition blocks instead of the shape (0: the shape).", min=0
    )
    preburn_area_m2: float = hyperparameter(
        0.0, "If > 0: pre-burn until the fire has touched this area (m2).", name="preburn-area"
    )
    episode_seconds: float = hyperparameter(
        EPISODE_DEFAULTS.duration_s, "Time limit of an episode (training and evaluation)."
    )
    buffer_size: int = hyperparameter(70_000, "Replay capacity in transitions.", min=1)
    learning_starts: int = hyperparameter(
        35_000, "Random-action samples that prefill the replay before training.", min=0
    )
    train_frequency: int = hyperparameter(10, "New samples per training iteration.", min=1)
    batch_size: int = hyperparameter(64, "Mini-batch size.", min=1)
    gamma: float = hyperparameter(0.99, "Discount factor.", unit=True)
    n_step: int = hyperparameter(
        20, "Decisions summed in a Bellman target (1: the paper's one-step DQN).", min=1
    )
    reward_scale: float = hyperparameter(
        0.01, "Rewards are multiplied by this in the targets (Q-values of order 1)."
    )
    learning_rate: float = hyperparameter(2.5e-4, "AdaMax step size.", name="lr")
    max_grad_norm: float = hyperparameter(10.0, "Gradient-norm clip.")
    start_e: float = hyperparameter(1.0, "Initial exploration probability.", unit=True)
    end_e: float = hyperparameter(
        0.5,
        "Final exploration probability (the paper's: 0.1; see the docstring of dqn.py).",
        unit=True,
    )
    exploration_samples: int = hyperparameter(
        111_111,
        "Samples over which epsilon falls linearly from ``start_e`` to ``end_e`` (the default "
        "keeps the slope of 1 -> 0.1 over 200 000).",
        min=0,
    )
    explore_hold: int = hyperparameter(
        20,
        "A random action is held for 1..explore_hold decisions (1: plain epsilon-greedy).",
        min=1,
    )
    double_q: bool = hyperparameter(
        True,
        "Double DQN targets (the online network picks the next action, the target scores it).",
    )
    dueling: bool = hyperparameter(
        False, "Dueling head: a state value plus the actions' advantages (q_network.py)."
    )
    prioritized: bool = hyperparameter(
        False,
        "Prioritised replay: transitions drawn in proportion to their last Bellman error "
        "(replay.py).",
    )
    priority_alpha: float = hyperparameter(
        0.6, "Prioritised replay: exponent of the priorities (0 would be uniform).", unit=True
    )
    priority_beta: float = hyperparameter(
        0.4,
        "Prioritised replay: importance-weight exponent at the first iteration (rises "
        "linearly to 1 at the last).",
        unit=True,
    )
    target_network_frequency: int = hyperparameter(
        1000, "Training iterations between target-network copies.", min=1
    )
    teacher: str = hyperparameter(
        "none",
        "A planner that labels the student's states with its next action, pulled towards by a "
        "large-margin loss (``none``: pure DQN; see teacher.py).",
        choices=TEACHERS,
    )
    teacher_weight: float = hyperparameter(
        1.0, "Weight of the teacher's margin loss at the first iteration (then falls linearly)."
    )
    teacher_margin: float = hyperparameter(
        0.02, "Lead, in Q units, that the teacher's action must have over the other."
    )
    teacher_iterations: int = hyperparameter(
        4000,
        "Iterations over which the teacher's weight falls to 0 (labelling stops then).",
        min=1,
    )
    eval_every: int = hyperparameter(
        10_000, "Training iterations between evaluations (0: only at the end).", min=0
    )
    eval_episodes: int = hyperparameter(20, "Held-out episodes per evaluation.", min=1)
    eval_shapes: tuple[str, ...] = hyperparameter(
        ("circular",),
        "Fire shapes of evaluation episodes (the paper's training curve: circular, 2 aircraft).",
    )
    checkpoint_every: int = hyperparameter(
        5_000, "Training iterations between checkpoints (0: only at the end).", min=0
    )
    torch_threads: int = hyperparameter(
        1, "Threads of torch (the machine is shared: 1 or 2).", min=1
    )
    channels_last: bool = hyperparameter(
        True, "Run the network in channels-last memory format (~20-40 % faster convolutions here)."
    )

    def validate(self) -> TrainConfig:
        """Return self, or raise :class:`LearningError` naming the bad field."""
        if self.approach not in IMAGE_SHAPES:
            raise LearningError(f"approach: expected obs or belief, got {self.approach!r}")
        for spec in fields(self):
            least = spec.metadata.get("min")
            if least is not None and getattr(self, spec.name) < least:
                raise LearningError(
                    f"{spec.name}: expected >= {least}, got {getattr(self, spec.name)}"
                )
        if not 0.0 < self.gamma <= 1.0:
            raise LearningError(f"gamma: expected a number in (0, 1], got {self.gamma}")
        if self.n_step > 255:
            raise LearningError(f"n_step: expected <= 255, got {self.n_step}")
        if not self.reward_scale > 0:
            raise LearningError(f"reward_scale: expected > 0, got {self.reward_scale}")
        if not self.learning_rate > 0:
            raise LearningError(f"learning_rate: expected > 0, got {self.learning_rate}")
        if not 0.0 <= self.end_e <= self.start_e <= 1.0:
            raise LearningError("epsilon: expected 0 <= end_e <= start_e <= 1")
        if self.reward not in REWARDS:
            raise LearningError(f"reward: expected one of {REWARDS}, got {self.reward!r}")
        if self.teacher not in TEACHERS:
            raise LearningError(f"teacher: expected one of {TEACHERS}, got {self.teacher!r}")
        if self.teacher == ORACLE_POLICY and (self.sensor != "disc" or not self.comm_model().ideal):
            raise LearningError(
                "teacher: oracle plans on the paper's world only (expected --sensor disc and "
                f"--comm ideal, got {self.sensor} and {self.comm})"
            )
        if not (self.teacher_weight > 0 and self.teacher_margin > 0):
            raise LearningError("teacher: expected teacher_weight > 0 and teacher_margin > 0")
        if not (0.0 <= self.priority_alpha <= 1.0 and 0.0 <= self.priority_beta <= 1.0):
            raise LearningError("priority: expected priority_alpha and priority_beta in [0, 1]")
        self.q_network()  # checks the architecture name
        self.env_config()
        self.eval_env_config()
        return self

    def q_network(self) -> nn.Module:
        """A freshly initialised Q-network of the run's approach, arch, sensor and head."""
        return build_q_network(self.approach, self.arch, self.sensor, self.dueling)

    def network_name(self) -> str:
        """``obs/paper``, ``belief/lite+dueling``: the network, as messages name it."""
        return network_name(self.approach, self.arch, self.dueling)

    def env_config(self) -> EnvConfig:
        """Environment of training episodes."""
        return EnvConfig(
            n_aircraft=self.n_aircraft,
            observation=self.approach,
            reward=self.reward_kind(),
            shapes=tuple(self.shapes),
            max_wind=self.max_wind,
            max_duration_s=self.episode_seconds,
            comm=self.comm_model(),
            sensor=self.sensor,
            pixel_error=self.pixel_error,
            wind_filter=self.wind_filter,
            **self.map_settings(),
        ).validate()

    def map_settings(self) -> dict[str, Any]:
        """The map's :class:`EnvConfig` fields (``wildfire_sim.landscape.read_landscape``)."""
        try:
            geometry = MapGeometry.parse(self.map_size)
        except MapGeometryError as error:
            raise LearningError(str(error)) from None
        given = None if geometry.is_paper and self.fuel_map else geometry
        landscape = read_landscape(
            given,
            Path(self.fuel_map) if self.fuel_map else None,
            self.fuel_classes or None,
            Path(self.ignition_map) if self.ignition_map else None,
            self.ignitions,
        )
        return {
            "geometry": landscape.geometry if landscape else geometry,
            "landscape": landscape,
            "preburn_area_m2": self.preburn_area_m2,
        }

    def reward_kind(self) -> str:
        """The approach whose reward the run trains on (``obs`` or ``belief``)."""
        return self.approach if self.reward == "approach" else self.reward

    def comm_model(self) -> CommModel:
        """The radio model of ``comm``, or :class:`LearningError` naming it."""
        try:
            return CommModel.parse(self.comm)
        except CommError as error:
            raise LearningError(str(error)) from None

    def eval_env_config(self) -> EnvConfig:
        """Environment of evaluation episodes (the score is the team reward either way)."""
        return replace(self.env_config(), shapes=tuple(self.eval_shapes))

    def eval_seeds(self) -> list[int]:
        return list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + self.eval_episodes))

    def epsilon_at(self, samples: int) -> float:
        """Exploration probability after ``samples`` samples."""
        return linear_schedule(self.start_e, self.end_e, self.exploration_samples, samples)

    def teacher_weight_at(self, iteration: int) -> float:
        """Weight of the teacher's margin loss at training ``iteration`` (0 without one)."""
        if self.teacher == "none":
            return 0.0
        return linear_schedule(self.teacher_weight, 0.0, self.teacher_iterations, iteration)

    def priority_exponents_at(self, iteration: int) -> tuple[float, float]:
        """Prioritised replay's (alpha, beta) at training ``iteration``; (0, 0) is uniform."""
        if not self.prioritized:
            return 0.0, 0.0
        beta = linear_schedule(self.priority_beta, 1.0, self.target_iterations(), iteration)
        return self.priority_alpha, beta

    def target_iterations(self) -> int:
        """Iterations the run will do."""
        if self.iterations > 0:
            return self.iterations
        return max(0, (self.total_samples - self.learning_starts) // self.train_frequency)


@dataclass
class RunOptions:
    """Where and how a run writes its files (not hyperparameters)."""

    run_dir: Path
    out: Path
    resume: bool = False
    baseline_score: float | None = None
    """Receding-horizon score on the evaluation seeds (drawn as a dashed line)."""
    bag_dirs: tuple[Path, ...] = ()
    """Recorded bags whose transitions prefill the replay."""
    offline: bool = False
    """Train on the bag transitions only (no environment interaction)."""
    init_policy: Path | None = None
    """Start from the weights of this exported policy (fine-tuning) instead of random ones."""
    device: str = "cpu"
    """Torch device of the networks and mini-batches (resolved: ``cpu``, ``cuda``, ``cuda:1``)."""
    time_limit_s: float | None = None
    """Stop this session's learning after this much wall time (the prefill included), then
    evaluate and export as at the end; ``--resume`` carries on towards the run's target."""


@dataclass
class TrainState:
    """Counters of a run (saved in checkpoints)."""

    samples: int = 0
    """Aircraft decisions taken in training episodes."""
    iterations: int = 0
    """Gradient steps done."""
    episodes: int = 0
    """Training episodes started (the next training seed)."""
    wall_time_s: float = 0.0
    """Wall time spent in this run over all sessions."""
    train_wall_s: float = 0.0
    """Wall time of the training phase (after the prefill)."""
    train_samples: int = 0
    """Samples taken during the training phase."""
    last_loss: float = float("nan")
    curve: list[dict[str, float]] = field(default_factory=list)
    """Learning-curve rows (``plots.CURVE_FIELDS``)."""
    initialised_from: dict[str, Any] | None = None
    """The exported policy a fine-tuning run started from (kept across ``--resume``)."""

    @property
    def last_score(self) -> float | None:
        """Score of the latest evaluation, if any."""
        return self.curve[-1]["score_mean"] if self.curve else None


def replay_shapes(config: TrainConfig) -> tuple[tuple[int, int, int], tuple[int, int]]:
    """Shapes of a replay frame: the image (C, H, W) and the pairwise states (K, 5)."""
    return image_shape(config.approach, config.sensor), (peer_count(config.n_aircraft), STATE_SIZE)


def config_from_dict(values: Mapping[str, Any]) -> TrainConfig:
    """A config from saved or given values (lists read as tuples, unknown keys ignored)."""
    known = {f.name for f in fields(TrainConfig)}
    kept: dict[str, Any] = {
        k: (tuple(v) if isinstance(v, list) else v) for k, v in values.items() if k in known
    }
    return TrainConfig(**kept)


def upgrade_saved_config(saved: Mapping[str, Any]) -> dict[str, Any]:
    """A checkpoint's config with the fields it predates set to their original behaviour."""
    return {k: v for k, v in PRE_EXTENSION_VALUES.items() if k not in saved} | dict(saved)


def given_values(config: TrainConfig | Mapping[str, Any]) -> dict[str, Any]:
    """The values of ``config`` given explicitly: a mapping's own (field names checked), or
    the fields of a :class:`TrainConfig` that differ from their defaults."""
    if isinstance(config, TrainConfig):
        return {
            spec.name: getattr(config, spec.name)
            for spec in fields(TrainConfig)
            if getattr(config, spec.name) != spec.default
        }
    known = {f.name for f in fields(TrainConfig)}
    unknown = sorted(set(config) - known)
    if unknown:
        raise LearningError(f"config: unknown hyperparameter(s) {', '.join(unknown)}")
    return dict(config)


def resolve_config(saved: Mapping[str, Any] | None, given: Mapping[str, Any]) -> TrainConfig:
    """The config of a run: defaults < ``saved`` (a checkpoint's config, upgraded; None for
    a new run) < ``given`` (the values given explicitly, see :func:`given_values`)."""
    values = upgrade_saved_config(saved) if saved is not None else {}
    return config_from_dict(values | dict(given))


__all__ = [
    "EVAL_SEED_BASE",
    "PRE_EXTENSION_VALUES",
    "REWARDS",
    "TEACHERS",
    "RunOptions",
    "TrainConfig",
    "TrainState",
    "config_from_dict",
    "given_values",
    "hyperparameter",
    "linear_schedule",
    "replay_shapes",
    "resolve_config",
    "upgrade_saved_config",
]
