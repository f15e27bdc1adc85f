"""Score against radio range: every policy under a list of radio models (``wildfire report
--comm-sweep``), as a table and a figure.

Each (policy, radio model) is one evaluation on the same seeds (``wildfire report``'s stored
evaluations, fingerprinted with the model). Cells give mean +- s.e. and the fraction of the
policy's own score under ideal links on the same seeds (paired): what the links cost it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from wildfire_belief.radio import CommModel
from wildfire_learning.results_report import policy_label
from wildfire_learning.summary_stats import standard_error


def comm_label(model: CommModel) -> str:
    """Column title of a radio model: ``ideal``, ``none`` or e.g. ``300 m, 20 % loss``."""
    if model.ideal or not model.links:
        return str(model)
    parts = [f"{model.range_m:g} m" if np.isfinite(model.range_m) else "any range"]
    if model.loss:
        parts.append(f"{model.loss:.0%} loss")
    if model.delay:
        parts.append(f"{model.delay} decisions late")
    return ", ".join(parts)


def fraction_of_ideal(result: dict[str, Any], ideal: dict[str, Any] | None) -> str:
    """``(97 +- 1 % of ideal)``: the paired ratio to the same policy under ideal links."""
    if ideal is None:
        return ""
    scores, base = np.array(result["scores"]), np.array(ideal["scores"])
    mean = float(base.mean())
    ratio, sem = scores.mean() / mean, standard_error(scores - base) / mean
    return f" ({ratio:.0%} +- {sem:.0%} of ideal)"


def sweep_markdown(
    results: dict[str, dict[str, dict[str, Any]]],
    models: list[CommModel],
    policies: list[str],
    scenario_title: str,
    protocol: str,
) -> str:
    """``results[str(model)][policy]`` (evaluation JSON) -> the sweep's table."""
    ideal = next((str(m) for m in models if m.ideal), None)
    lines = [
        f"# Score against radio links ({scenario_title})",
        "",
        protocol,
        "",
        "Mean +- standard error of the score (the union of every aircraft's visits), and in",
        "brackets the fraction of the same policy's score under ideal links on the same seeds",
        "(+- the standard error of the paired difference).",
        "",
        "| policy | " + " | ".join(comm_label(m) for m in models) + " |",
        "|---" * (len(models) + 1) + "|",
    ]
    for policy in policies:
        row = [policy_label(policy)]
        base = results[ideal][policy] if ideal is not None else None
        for model in models:
            result = results[str(model)][policy]
            share = "" if model.ideal else fraction_of_ideal(result, base)
            row.append(f"{result['score_mean']:.1f} +- {result['score_sem']:.1f}{share}")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def plot_sweep(
    results: dict[str, dict[str, dict[str, Any]]],
    models: list[CommModel],
    policies: list[str],
    path: Path,
) -> None:
    """Score (mean +- s.e.) of each policy across the radio models, in the given order."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.arange(len(models))
    fig, ax = plt.subplots(figsize=(1.5 + 1.2 * len(models), 4))
    for policy in policies:
        means = [results[str(m)][policy]["score_mean"] for m in models]
        sems = [results[str(m)][policy]["score_sem"] for m in models]
        ax.errorbar(x, means, yerr=sems, marker="o", capsize=3, label=policy_label(policy))
    ax.set_xticks(x, [comm_label(m) for m in models], fontsize=8)
    ax.set_xlabel("radio links")
    ax.set_ylabel("Average Reward Accumulated")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


__all__ = ["comm_label", "fraction_of_ideal", "plot_sweep", "sweep_markdown"]
