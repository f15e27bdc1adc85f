"""What a training run tells while it runs: its status, its wall time, its speed.

A run may span several sessions (``--resume``). :class:`Session` times the current one: the run's
wall time adds it to the earlier sessions' (saved in the checkpoint), and the training phase is
timed apart from the replay prefill, because the prefill only steps environments and its rate
says nothing about the speed of training.
"""

from __future__ import annotations

import resource
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from wildfire_learning.train_config import TrainConfig, TrainState


@dataclass
class Status:
    """What the progress callback sees."""

    samples: int
    iterations: int
    target_iterations: int
    epsilon: float
    loss: float
    last_score: float | None
    phase: str


def report_status(
    report: Callable[[Status], None] | None,
    state: TrainState,
    config: TrainConfig,
    phase: str,
    epsilon: float | None = None,
) -> None:
    """Tell the progress callback, if any (``epsilon`` defaults to the schedule's)."""
    if report is not None:
        report(
            Status(
                state.samples,
                state.iterations,
                config.target_iterations(),
                config.epsilon_at(state.samples) if epsilon is None else epsilon,
                state.last_loss,
                state.last_score,
                phase,
            )
        )


@dataclass
class Session:
    """Wall-clock bookkeeping of one session of a run (a resumed run starts a new one)."""

    wall_before_s: float
    """Wall time of the run's earlier sessions."""
    samples0: int
    """Samples when the training phase started (after the prefill)."""
    iterations0: int
    """Iterations when the training phase started."""
    start: float = field(default_factory=time.perf_counter)
    train_start: float | None = None
    prefill_samples: int = 0
    prefill_rate: float = 0.0

    def wall_time_s(self) -> float:
        """Wall time of the run so far, earlier sessions included."""
        return self.wall_before_s + time.perf_counter() - self.start

    def out_of_time(self, limit_s: float | None) -> bool:
        """Whether this session has used up its wall-time limit (never, without one)."""
        return limit_s is not None and time.perf_counter() - self.start >= limit_s

    def start_training(self, state: TrainState) -> None:
        """Mark the end of the prefill (once): training-phase rates count from here."""
        if self.train_start is not None:
            return
        self.train_start = time.perf_counter()
        self.samples0, self.iterations0 = state.samples, state.iterations
        if self.prefill_samples:
            self.prefill_rate = self.prefill_samples / (self.train_start - self.start)

    def train_wall_s(self) -> float:
        """Wall time of this session's training phase so far (0 before it started)."""
        return time.perf_counter() - self.train_start if self.train_start else 0.0

    def training_rates(self, state: TrainState) -> tuple[float, float]:
        """This session's training-phase samples/s and iterations/s so far (0 before)."""
        train_wall = self.train_wall_s()
        if train_wall <= 0:
            return 0.0, 0.0
        samples = state.samples - self.samples0
        return samples / train_wall, (state.iterations - self.iterations0) / train_wall

    def close(self, state: TrainState) -> tuple[float, float]:
        """Add this session's training phase to ``state``'s totals; return its samples/s and
        iterations/s (0 when it never trained)."""
        rates = self.training_rates(state)
        state.train_wall_s += self.train_wall_s()
        state.train_samples += state.samples - self.samples0
        return rates


def max_rss_mb() -> float:
    """Peak resident memory of this process (MB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


__all__ = ["Session", "Status", "max_rss_mb", "report_status"]
