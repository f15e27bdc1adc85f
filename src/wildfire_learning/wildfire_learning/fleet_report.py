"""Does coordination matter? The score against the fleet's size, from a report's scenarios.

Scenarios that differ only in their number of aircraft (the same kind, map, fire and
ignitions: ``field:1000x1000:ignitions=5:aircraft=4`` ... ``aircraft=32``) form a fleet
series. For each, :func:`fleet_markdown` tabulates every policy's fraction of the score
ceiling by fleet size, with the ceiling (the fire's alone, so the same for every fleet on
the same seeds), and :func:`plot_fleet` draws it: where the curves level off near the
ceiling, more aircraft have nothing left to coordinate.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import replace
from pathlib import Path
from typing import Any

from wildfire_learning.report_scenarios import Scenario

Results = dict[str, dict[str, dict[str, Any]]]
"""``results[scenario_key][policy]``: an evaluation's JSON."""


def fleet_series(scenarios: list[Scenario]) -> dict[str, list[Scenario]]:
    """Scenarios by their world (title without the fleet), where a world has two fleets or
    more, each series by fleet size."""
    groups: dict[Scenario, list[Scenario]] = defaultdict(list)
    for scenario in scenarios:
        groups[replace(scenario, aircraft=1)].append(scenario)
    return {
        world.title.removesuffix(", 1 aircraft"): sorted(members, key=lambda s: s.aircraft)
        for world, members in groups.items()
        if len({s.aircraft for s in members}) > 1
    }


def fleet_markdown(results: Results, scenarios: list[Scenario], policies: list[str]) -> str:
    """One table per fleet series: the ceiling fraction of every policy by fleet size."""
    from wildfire_learning.results_report import policy_label

    lines: list[str] = []
    for world, series in fleet_series(scenarios).items():
        lines += [
            f"## Score against fleet size: {world}",
            "",
            "Fraction of the score ceiling (mean score in brackets) by the number of aircraft,",
            "the same seeds for every fleet:",
            "",
            "| policy | " + " | ".join(f"{s.aircraft} aircraft" for s in series) + " |",
            "|---" * (len(series) + 1) + "|",
        ]
        for policy in policies:
            cells = [results[s.key][policy] for s in series]
            lines.append(
                f"| {policy_label(policy)} | "
                + " | ".join(f"{c['ceiling_fraction']:.0%} ({c['score_mean']:.0f})" for c in cells)
                + " |"
            )
        ceilings = [next(iter(results[s.key].values()))["score_ceiling_mean"] for s in series]
        lines += ["| ceiling | " + " | ".join(f"{c:.0f}" for c in ceilings) + " |", ""]
    return "\n".join(lines)


def plot_fleet(
    results: Results, scenarios: list[Scenario], policies: list[str], path: Path
) -> bool:
    """Ceiling fraction against fleet size, a panel per fleet series; False if none."""
    series_by_world = fleet_series(scenarios)
    if not series_by_world:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from wildfire_learning.results_report import policy_label

    fig, axes = plt.subplots(
        1, len(series_by_world), figsize=(4.5 * len(series_by_world), 3.6), squeeze=False
    )
    for ax, (world, series) in zip(axes[0], series_by_world.items(), strict=True):
        fleets = [s.aircraft for s in series]
        for policy in policies:
            fractions = [results[s.key][policy]["ceiling_fraction"] for s in series]
            ax.plot(fleets, fractions, marker="o", label=policy_label(policy))
        ax.set_xscale("log", base=2)
        ax.set_xticks(fleets, [str(n) for n in fleets])
        ax.set_ylim(0, 1)
        ax.set_xlabel("aircraft")
        ax.set_ylabel("fraction of the score ceiling")
        ax.set_title(world, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


__all__ = ["fleet_markdown", "fleet_series", "plot_fleet"]
