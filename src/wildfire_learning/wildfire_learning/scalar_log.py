"""A training run's scalars for TensorBoard, beside its CSV learning curve (as CleanRL logs).

:class:`ScalarLog` writes event files under ``<run dir>/tensorboard``: ``tensorboard --logdir
<run dir>`` shows them (TensorBoard itself is not a dependency; ``tensorboardX`` writes its
file format with only numpy and protobuf). The x axis is the sample count, CleanRL's
``global_step``, so a resumed run continues its curves in the same folder.

* every :data:`TRAINING_EVERY` iterations: ``losses/td_loss``, ``charts/epsilon``,
  ``charts/iterations_per_s`` and ``charts/samples_per_s`` (of this session's training
  phase, as the run's summary counts them); with a teacher, while it has weight, also
  ``losses/teacher_loss``, ``charts/teacher_weight`` and ``charts/teacher_agreement`` (the
  fraction of the mini-batch's labelled states where the network already picks the label);
* at every evaluation: ``eval/score``, ``eval/score_sem``, ``eval/belief_iou``,
  ``eval/reward_mean``, ``eval/q_predicted`` and ``eval/q_collected`` (the greedy policy's
  predicted and collected discounted returns).
"""

from __future__ import annotations

import math
from pathlib import Path
from types import TracebackType

from tensorboardX import SummaryWriter

from wildfire_learning.teacher import TeacherStats
from wildfire_learning.train_config import TrainState

TRAINING_EVERY = 100
"""Iterations between two logs of the training scalars (CleanRL logs every 100 steps)."""
EVAL_SCALARS = {
    "eval/score": "score_mean",
    "eval/score_sem": "score_sem",
    "eval/belief_iou": "belief_iou_mean",
    "eval/reward_mean": "reward_mean",
    "eval/q_predicted": "q_predicted",
    "eval/q_collected": "q_collected",
}
"""TensorBoard tag of each learning-curve column logged at an evaluation."""


def log_dir(run_dir: Path) -> Path:
    """Where a run's event files go."""
    return run_dir / "tensorboard"


class ScalarLog:
    """The scalars of one session of a run (see the module docstring); a context manager."""

    def __init__(self, run_dir: Path) -> None:
        self.writer = SummaryWriter(str(log_dir(run_dir)))

    def training(
        self,
        state: TrainState,
        epsilon: float,
        rates: tuple[float, float],
        teacher: TeacherStats | None = None,
    ) -> None:
        """The training scalars, every :data:`TRAINING_EVERY` iterations; ``rates``: the
        session's training-phase samples/s and iterations/s (``Session.training_rates``);
        ``teacher``: the last mini-batch's teacher figures, in a run with a teacher."""
        if state.iterations % TRAINING_EVERY:
            return
        samples = state.samples
        if math.isfinite(state.last_loss):  # NaN until the first iteration
            self.writer.add_scalar("losses/td_loss", state.last_loss, samples)
        if teacher is not None:
            self.writer.add_scalar("losses/teacher_loss", teacher.loss, samples)
            self.writer.add_scalar("charts/teacher_weight", teacher.weight, samples)
            if math.isfinite(teacher.agreement):
                self.writer.add_scalar("charts/teacher_agreement", teacher.agreement, samples)
        self.writer.add_scalar("charts/epsilon", epsilon, samples)
        self.writer.add_scalar("charts/samples_per_s", rates[0], samples)
        self.writer.add_scalar("charts/iterations_per_s", rates[1], samples)

    def evaluation(self, row: dict[str, float]) -> None:
        """One learning-curve row (``plots.CURVE_FIELDS``); columns it lacks or holds as NaN
        are left out."""
        samples = int(row["samples"])
        for tag, column in EVAL_SCALARS.items():
            value = row.get(column)
            if value is not None and math.isfinite(value):
                self.writer.add_scalar(tag, value, samples)
        self.writer.flush()

    def close(self) -> None:
        self.writer.close()

    def __enter__(self) -> ScalarLog:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()


__all__ = ["EVAL_SCALARS", "TRAINING_EVERY", "ScalarLog", "log_dir"]
