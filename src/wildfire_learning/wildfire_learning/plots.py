"""Figures in the style of the paper: fire propagation, flight paths over the fire, and the
learning curve of a training run (with its CSV, rewritten at every evaluation)."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only: never open a window
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap
from matplotlib.image import AxesImage

from wildfire_learning.summary_stats import standard_error
from wildfire_sim.grid import geometry_of

CURVE_CSV = "learning_curve.csv"
CURVE_PNG = "learning_curve.png"
SEED_CURVES_CSV = "learning_curves.csv"
SEED_CURVES_PNG = "learning_curves.png"
CURVE_FIELDS = (
    "iteration",
    "samples",
    "wall_time_s",
    "epsilon",
    "score_mean",
    "score_sem",
    "belief_iou_mean",
    "episodes",
    "q_predicted",
    "q_collected",
    "reward_mean",
)
"""Columns of the learning curve: one row per evaluation of a training run."""
SEED_CURVE_FIELDS = ("iteration", "runs", "score_mean", "score_sem", "reward_mean", "reward_sem")
"""Columns of a learning curve over several runs: means and standard errors across runs."""
# 0 unburnt, 1 burnt out, 2 burning.
FIRE_COLOURS = ListedColormap(["#f4f1e8", "#5b5b5b", "#e8491d"])


def fire_state_image(burning: np.ndarray, affected: np.ndarray) -> np.ndarray:
    """0 unburnt, 1 burnt (affected, not burning), 2 burning."""
    return np.where(burning, 2, np.where(affected, 1, 0))


def map_extent(grid: np.ndarray) -> tuple[float, float, float, float]:
    """(west, east, south, north) in metres of a map-sized grid (its last two axes)."""
    geometry = geometry_of(grid)
    return (0.0, geometry.width_m, 0.0, geometry.height_m)


def _show_grid(ax: Axes, grid: np.ndarray, **style: Any) -> AxesImage:
    """Draw a map-frame grid (row 0 at the south) over the map it covers."""
    extent = map_extent(grid)
    return ax.imshow(grid, origin="lower", extent=extent, interpolation="nearest", **style)


def _show_fire(ax: Axes, truth: np.ndarray, alpha: float = 1.0) -> None:
    """Draw a ``fire_state_image``: unburnt, burnt out, burning."""
    _show_grid(ax, truth, cmap=FIRE_COLOURS, vmin=0, vmax=2, alpha=alpha)


def _map_axes(ax: Axes, title: str, grid: np.ndarray) -> None:
    west, east, south, north = map_extent(grid)
    ax.set_title(title, fontsize=9)
    ax.set_xlim(west, east)
    ax.set_ylim(south, north)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)


def plot_fire_propagation(
    frames: Sequence[tuple[int, np.ndarray, np.ndarray, np.ndarray]],
    path: str | Path,
    title: str,
) -> None:
    """Rows of (fire, fuel) maps; ``frames`` holds (fire step, burning, affected, fuel)."""
    fig, axes = plt.subplots(len(frames), 2, figsize=(6, 2.9 * len(frames)), squeeze=False)
    for row, (step, burning, affected, fuel) in enumerate(frames):
        ax_fire, ax_fuel = axes[row]
        _show_fire(ax_fire, fire_state_image(burning, affected))
        _map_axes(ax_fire, f"fire locations, t = {step * 2.5:.0f} s", burning)
        image = _show_grid(ax_fuel, fuel, cmap="YlGn", vmin=0, vmax=22)
        _map_axes(ax_fuel, "fuel map", fuel)
        fig.colorbar(image, ax=ax_fuel, fraction=0.046)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_episode(
    burning: np.ndarray,
    affected: np.ndarray,
    believed: np.ndarray,
    trajectory: np.ndarray,
    path: str | Path,
    title: str,
) -> None:
    """True fire, shared belief, and flight paths over the fire; ``trajectory`` (T, N, 2)."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6))
    truth = fire_state_image(burning, affected)
    _show_fire(axes[0], truth)
    _map_axes(axes[0], "true fire (red burning, grey burnt)", burning)
    _show_grid(axes[1], believed, cmap="Reds", vmin=0, vmax=1.5)
    _map_axes(axes[1], "shared belief (believed burning)", burning)
    _show_fire(axes[2], truth, alpha=0.6)
    colours = plt.cm.tab10(np.arange(trajectory.shape[1]) % 10)
    for k in range(trajectory.shape[1]):
        xy = trajectory[:, k]
        axes[2].plot(xy[:, 0], xy[:, 1], color=colours[k], lw=1.0, label=f"uav{k}")
        axes[2].plot(*xy[0], "o", color=colours[k], ms=4)
        axes[2].plot(*xy[-1], ">", color=colours[k], ms=6)
    axes[2].legend(fontsize=7, loc="upper right")
    _map_axes(axes[2], "flight paths (o start, > end)", burning)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_learning_curve(
    rows: Sequence[dict[str, float]], baseline: float | None, title: str, path: str | Path
) -> None:
    """Score (mean +- sem per evaluation) vs thousands of training iterations, with the
    receding-horizon score dashed when known (the paper's figure)."""
    x = np.array([r["iteration"] for r in rows]) / 1000.0
    y = np.array([r["score_mean"] for r in rows])
    err = np.array([r["score_sem"] for r in rows])
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.errorbar(x, y, yerr=err, marker="o", ms=3, capsize=2, color="black", label=title)
    if baseline is not None:
        ax.axhline(baseline, ls="--", color="grey", label="receding horizon")
    ax.set_xlabel("Thousands of Training Iterations")
    ax.set_ylabel("Average Reward Accumulated")
    ax.legend(loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_curve(
    run_dir: Path, rows: list[dict[str, float]], baseline: float | None, title: str
) -> None:
    """Learning curve of a run as ``CURVE_CSV`` and ``CURVE_PNG`` in ``run_dir``."""
    with open(run_dir / CURVE_CSV, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=CURVE_FIELDS)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: row.get(k, "") for k in CURVE_FIELDS})
    if rows:
        plot_learning_curve(rows, baseline, title, run_dir / CURVE_PNG)


def read_curve(path: Path) -> list[dict[str, float]]:
    """The rows of a ``CURVE_CSV`` as numbers (a column an older run lacks reads as nan)."""
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    return [
        {k: float(v) if v not in ("", None) else float("nan") for k, v in r.items()} for r in rows
    ]


def seed_curve(curves: Sequence[Sequence[dict[str, float]]]) -> list[dict[str, float]]:
    """Mean +- standard error across runs (e.g. training seeds) of the validation score and
    of ``reward_mean``, at each iteration every run evaluated at.

    The error is the spread between runs, not the episodes' standard error within one: it is
    what says whether a curve's shape belongs to the recipe or to one seed.
    """
    by_iteration = [{r["iteration"]: r for r in curve} for curve in curves]
    shared = sorted(set.intersection(*(set(run) for run in by_iteration)))
    rows = []
    for iteration in shared:
        at = [run[iteration] for run in by_iteration]
        scores = np.array([r["score_mean"] for r in at])
        rewards = np.array([r.get("reward_mean", np.nan) for r in at])
        rows.append(
            {
                "iteration": iteration,
                "runs": len(curves),
                "score_mean": float(scores.mean()),
                "score_sem": standard_error(scores),
                "reward_mean": float(rewards.mean()),
                "reward_sem": standard_error(rewards),
            }
        )
    return rows


def write_seed_curves(
    curves: Sequence[Sequence[dict[str, float]]],
    labels: Sequence[str],
    baseline: float | None,
    out_dir: Path,
) -> list[dict[str, float]]:
    """``SEED_CURVES_CSV`` (:func:`seed_curve`) and ``SEED_CURVES_PNG`` in ``out_dir``: the
    mean +- s.e. over runs, each run thin behind it, and the training reward below."""
    rows = seed_curve(curves)
    with open(out_dir / SEED_CURVES_CSV, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=SEED_CURVE_FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    fig, (ax_score, ax_reward) = plt.subplots(
        2, 1, figsize=(6, 6), sharex=True, gridspec_kw={"height_ratios": [2, 1]}
    )
    for curve, label in zip(curves, labels, strict=True):
        x = np.array([r["iteration"] for r in curve]) / 1000.0
        ax_score.plot(x, [r["score_mean"] for r in curve], lw=0.8, alpha=0.5, label=label)
        ax_reward.plot(x, [r.get("reward_mean", np.nan) for r in curve], lw=0.8, alpha=0.5)
    if rows:
        x = np.array([r["iteration"] for r in rows]) / 1000.0
        for ax, key in ((ax_score, "score"), (ax_reward, "reward")):
            mean = np.array([r[f"{key}_mean"] for r in rows])
            sem = np.array([r[f"{key}_sem"] for r in rows])
            ax.plot(x, mean, color="black", marker="o", ms=3, label=f"mean of {len(curves)}")
            ax.fill_between(x, mean - sem, mean + sem, color="black", alpha=0.15)
    if baseline is not None:
        ax_score.axhline(baseline, ls="--", color="grey", label="receding horizon")
    ax_score.set_ylabel("Average Reward Accumulated")
    ax_score.legend(loc="best", fontsize=8)
    ax_reward.set_ylabel("training reward\nper decision")
    ax_reward.set_xlabel("Thousands of Training Iterations")
    fig.tight_layout()
    fig.savefig(out_dir / SEED_CURVES_PNG, dpi=110)
    plt.close(fig)
    return rows


__all__ = [
    "CURVE_CSV",
    "CURVE_FIELDS",
    "CURVE_PNG",
    "SEED_CURVES_CSV",
    "SEED_CURVES_PNG",
    "SEED_CURVE_FIELDS",
    "fire_state_image",
    "plot_episode",
    "plot_fire_propagation",
    "plot_learning_curve",
    "read_curve",
    "seed_curve",
    "write_curve",
    "write_seed_curves",
]
