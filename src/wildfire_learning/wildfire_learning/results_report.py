"""Results report: the paper's results table, reproduced on this project's policies.

See docs/model.md, Evaluation.

Every (policy, scenario) pair is one :func:`~wildfire_learning.evaluate.evaluate` run on
the same seeds, so a row compares policies episode by episode. Each result is kept as JSON
in the report's ``evaluations/`` folder together with what produced it (the seeds, wind bound,
flight limit and, for a Q-network, the SHA-256 of its file; for ``oracle``, those of the
shipped networks whose flights are its incumbents): a later report reuses it while those are
unchanged, so adding a scenario or a policy flies only what is new. Results of ``rh``,
``rh-paper`` and ``random`` are keyed by their settings only; pass ``fresh`` after changing
their code.

The report itself is a Markdown table (mean +- standard error, ratio to our receding horizon
``rh``, fraction of the score ceiling), the paper's ratios beside ours, and a bar chart. The
paper's receding horizon is uncoordinated, so its ratios are set beside ours to ``rh-paper``
(the same baseline, docs/model.md, Baselines); ours to ``rh`` are given too.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from wildfire_agent.approaches import APPROACHES
from wildfire_agent.policy_names import (
    CAMERA_POLICY,
    CAMERA_RADIO_POLICY,
    OBS_CAMERA_POLICY,
    ORACLE_POLICY,
    RADIO_POLICY,
    SHIPPED_POLICIES,
    is_user_policy,
    resolve_policy_path,
)
from wildfire_belief.radio import IDEAL, CommModel
from wildfire_learning.model_card import policy_sha256
from wildfire_learning.oracle_incumbents import INCUMBENT_POLICIES
from wildfire_learning.report_scenarios import Scenario
from wildfire_learning.summary_stats import standard_error

POLICY_LABELS = {
    "obs": "observation DQN",
    "belief": "belief DQN",
    RADIO_POLICY: "belief DQN (radio-trained)",
    CAMERA_POLICY: "belief DQN (camera-trained)",
    CAMERA_RADIO_POLICY: "belief DQN (camera- and radio-trained)",
    OBS_CAMERA_POLICY: "observation DQN (camera-trained)",
    "rh": "receding horizon",
    "rh-paper": "receding horizon (paper)",
    "random": "random",
    ORACLE_POLICY: "oracle (clairvoyant bound)",
}
"""Column titles of the built-in policies (a .pt file is titled by its name)."""
WORLD_NETWORKS = {"obs": (OBS_CAMERA_POLICY, "obs"), "belief": (CAMERA_POLICY, "belief")}
"""The network that stands for an approach in the paper-ratio table: the camera-trained one
where it was flown (under cameras), else the shipped one."""
BASELINE = "rh"
"""Ratios of the main table are to this policy's score on the same seeds."""
PAPER_BASELINE = "rh-paper"
"""The paper's (uncoordinated) receding horizon: the paper's ratios are set beside ours to it."""
PAPER_RESULTS: dict[str, dict[str, tuple[float, float]]] = {
    "circular_2aircraft": {
        "obs": (3140.5, 130.1),
        "belief": (3154.3, 139.9),
        PAPER_BASELINE: (2725.6, 115.2),
    },
    "circular_3aircraft": {"obs": (3390.3, 146.2), "belief": (3337.2, 161.8)},
    "circular_4aircraft": {"obs": (3546.9, 152.1), "belief": (3463.8, 164.8)},
    "t_2aircraft": {
        "obs": (2601.3, 73.2),
        "belief": (2580.7, 66.2),
        PAPER_BASELINE: (2067.7, 78.7),
    },
    "arc_2aircraft": {
        "obs": (1789.4, 102.2),
        "belief": (1873.9, 112.3),
        PAPER_BASELINE: (1646.4, 103.0),
    },
}
"""Julian & Kochenderfer's results: mean and standard error per scenario; its
receding horizon is the uncoordinated one, ``rh-paper`` here."""
PAPER_SCENARIOS = ("circular:2", "circular:3", "circular:4", "t:2", "arc:2")


def policy_id(policy: str) -> str:
    """Short name of a policy in file names: its own, a policy file's stem, or the ATTR of
    a policy of your own (``MODULE:ATTR``)."""
    if policy in POLICY_LABELS:
        return policy
    return policy.rpartition(":")[2] if is_user_policy(policy) else Path(policy).stem


def policy_label(policy: str) -> str:
    """Column title of a policy name or policy file."""
    return POLICY_LABELS.get(policy, policy_id(policy))


def fingerprint(
    policy: str,
    policy_file: Path | None,
    seeds: list[int],
    max_wind: float,
    duration_s: float,
    comm: CommModel = IDEAL,
    sensor: str = "disc",
    pixel_error: float = 0.0,
    wind_filter: bool = False,
) -> dict[str, Any]:
    """What an evaluation depends on, beyond the code: equal fingerprints, equal results.

    The radio model and the sensor join it only when they are not the paper's (ideal links,
    the perfect disc): stored results of the paper's world keep their fingerprints."""
    identity: dict[str, Any] = {
        # Keyed "controller", the word for a policy before it had one word: stored results
        # (docs/results/evaluations) stay reusable.
        "controller": policy,
        "seeds": seeds,
        "max_wind": max_wind,
        "duration_s": duration_s,
    }
    if not comm.ideal:
        identity["comm"] = str(comm)
    if sensor != "disc" or pixel_error:
        identity["sensor"] = sensor
        identity["pixel_error"] = pixel_error
    if wind_filter:
        identity["wind_filter"] = True
    if policy_file is not None:
        identity["policy_sha256"] = policy_sha256(policy_file)
    if policy == ORACLE_POLICY:
        # The bound starts from the best flight of the shipped policies on each episode, so a
        # new shipped network can raise it: its stored results hold only with the same files.
        identity["incumbents_sha256"] = {
            name: policy_sha256(resolve_policy_path(name))
            for name in INCUMBENT_POLICIES
            if name in SHIPPED_POLICIES
        }
    return identity


def evaluation_path(
    out_dir: Path,
    policy: str,
    scenario: Scenario,
    comm: CommModel = IDEAL,
    sensor: str = "disc",
    pixel_error: float = 0.0,
    wind_filter: bool = False,
) -> Path:
    """Where an evaluation is stored:
    ``<policy>_<scenario>[_comm-<model>][_<sensor>-p<error>].json``."""
    suffix = "" if comm.ideal else "_comm-" + str(comm).replace(",", "_").replace("=", "")
    if sensor != "disc" or pixel_error:
        suffix += f"_{sensor}-p{pixel_error:g}" + ("-wind" if wind_filter else "")
    return out_dir / "evaluations" / f"{policy_id(policy)}_{scenario.key}{suffix}.json"


def load_cached(path: Path, identity: dict[str, Any]) -> dict[str, Any] | None:
    """The stored result at ``path`` if it was produced with ``identity``, else None."""
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(stored, dict) or stored.get("fingerprint") != identity:
        return None
    return stored


def store(path: Path, identity: dict[str, Any], result: dict[str, Any]) -> dict[str, Any]:
    stored = result | {"fingerprint": identity}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(stored, indent=1) + "\n")
    return stored


@dataclass(frozen=True)
class Cell:
    """One policy on one scenario, with its comparison to both baselines."""

    mean: float
    sem: float
    ceiling_fraction: float
    ratio: float | None
    """Mean over the mean of ``rh`` on the same seeds (None without it, or for ``rh``)."""
    ratio_sem: float | None
    """Standard error of the ratio: that of the per-seed difference to the baseline, over the
    baseline's mean (the seeds are shared, so this is much smaller than the scores' own)."""
    ratio_rh_paper: float | None = None
    """The same to ``rh-paper``."""
    ratio_rh_paper_sem: float | None = None
    oracle_fraction: float | None = None
    """Mean over the mean of the clairvoyant bound ``oracle`` on the same seeds (None
    without it): how close to the best team flight found the policy comes."""


def paired_ratio(
    scores: np.ndarray, baseline: dict[str, Any] | None
) -> tuple[float | None, float | None]:
    """Ratio of means to a baseline's evaluation on the same seeds, and its standard error
    (None where there is no baseline, or it scored nothing: every fire reached the border
    before the flight, say)."""
    if baseline is None:
        return None, None
    base_scores = np.array(baseline["scores"])
    mean = base_scores.mean()
    if mean == 0:
        return None, None
    return float(scores.mean() / mean), standard_error(scores - base_scores) / float(mean)


def table_cells(
    results: dict[str, dict[str, dict[str, Any]]],
) -> dict[str, dict[str, Cell]]:
    """``results[scenario_key][policy]`` (evaluation JSON) -> cells with ratios."""
    cells: dict[str, dict[str, Cell]] = {}
    for scenario, by_policy in results.items():
        row: dict[str, Cell] = {}
        for policy, result in by_policy.items():
            scores = np.array(result["scores"])
            ours = by_policy.get(BASELINE) if policy != BASELINE else None
            paper = by_policy.get(PAPER_BASELINE) if policy != PAPER_BASELINE else None
            bound, _ = paired_ratio(scores, by_policy.get(ORACLE_POLICY))
            row[policy] = Cell(
                float(result["score_mean"]),
                float(result["score_sem"]),
                float(result["ceiling_fraction"]),
                *paired_ratio(scores, ours),
                *paired_ratio(scores, paper),
                bound,
            )
        cells[scenario] = row
    return cells


def results_markdown(
    results: dict[str, dict[str, dict[str, Any]]],
    scenarios: list[Scenario],
    policies: list[str],
    protocol: str,
) -> str:
    """The report: our table, then the paper's ratios beside ours."""
    cells = table_cells(results)
    titles = [policy_label(c) for c in policies]
    lines = [
        "# Results",
        "",
        protocol,
        "",
        "Mean +- standard error of the score; in brackets the ratio to our receding horizon",
        "(`rh`) on the same seeds, the fraction of the score ceiling (the most any policy",
        "could score on those fires) and, where the clairvoyant bound `oracle` was flown, the",
        "fraction of its score on the same seeds.",
        "",
        "| scenario | ceiling | " + " | ".join(titles) + " |",
        "|---" * (len(titles) + 2) + "|",
    ]
    for scenario in scenarios:
        by_policy = results[scenario.key]
        ceiling = next(iter(by_policy.values()))["score_ceiling_mean"]
        row = [scenario.title, f"{ceiling:.1f}"]
        for policy in policies:
            cell = cells[scenario.key][policy]
            ratio = f"{cell.ratio:.2f}x, " if cell.ratio is not None else ""
            bound = f", {cell.oracle_fraction:.0%} of oracle" if cell.oracle_fraction else ""
            row.append(
                f"{cell.mean:.1f} +- {cell.sem:.1f} ({ratio}{cell.ceiling_fraction:.0%}{bound})"
            )
        lines.append("| " + " | ".join(row) + " |")
    paper_world = [scenario for scenario in scenarios if not scenario.is_field]
    if not paper_world:  # the paper has nothing to say about field maps
        return "\n".join(lines) + "\n"
    lines += [
        "",
        "Ratio to the receding horizon. The paper's (its episode length is not stated, so only",
        "ratios compare) is to its uncoordinated planner, which `rh-paper` reproduces; ours are",
        "to `rh-paper` and to our `rh` (+- the standard error of the paired per-seed",
        "difference, over the baseline's mean), for the camera-trained network of each",
        "approach where it was flown, else the shipped one:",
        "",
        "| scenario | paper observation | paper belief | ours observation / rh-paper | "
        "ours belief / rh-paper | ours observation / rh | ours belief / rh |",
        "|---|---|---|---|---|---|---|",
    ]
    for scenario in paper_world:
        paper = PAPER_RESULTS.get(scenario.key, {})
        ours = cells[scenario.key]

        def paper_ratio(approach: str, paper: dict[str, tuple[float, float]] = paper) -> str:
            if approach in paper and PAPER_BASELINE in paper:
                return f"{paper[approach][0] / paper[PAPER_BASELINE][0]:.2f}x"
            return "-"

        def our_ratio(approach: str, baseline: str, ours: dict[str, Cell] = ours) -> str:
            flown = [ours[name] for name in WORLD_NETWORKS[approach] if name in ours]
            if not flown:
                return "-"
            cell = flown[0]
            if baseline == BASELINE:
                ratio, sem = cell.ratio, cell.ratio_sem
            else:
                ratio, sem = cell.ratio_rh_paper, cell.ratio_rh_paper_sem
            return "-" if ratio is None else f"{ratio:.2f}x +- {sem:.2f}"

        lines.append(
            f"| {scenario.title} | {paper_ratio('obs')} | {paper_ratio('belief')} | "
            + " | ".join(
                our_ratio(approach, baseline)
                for baseline in (PAPER_BASELINE, BASELINE)
                for approach in APPROACHES
            )
            + " |"
        )
    return "\n".join(lines) + "\n"


def plot_scores(
    results: dict[str, dict[str, dict[str, Any]]],
    scenarios: list[Scenario],
    policies: list[str],
    path: Path,
) -> None:
    """Grouped bars (mean +- s.e.) per scenario, with each scenario's ceiling marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    width = 0.8 / len(policies)
    x = np.arange(len(scenarios))
    fig, ax = plt.subplots(figsize=(1.6 + 1.5 * len(scenarios), 4))
    for i, policy in enumerate(policies):
        means = [results[s.key][policy]["score_mean"] for s in scenarios]
        sems = [results[s.key][policy]["score_sem"] for s in scenarios]
        offset = (i - (len(policies) - 1) / 2) * width
        ax.bar(x + offset, means, width, yerr=sems, capsize=2, label=policy_label(policy))
    ceilings = [next(iter(results[s.key].values()))["score_ceiling_mean"] for s in scenarios]
    ax.hlines(ceilings, x - 0.45, x + 0.45, colors="black", linestyles="--", label="ceiling")
    if ORACLE_POLICY in policies:
        # The bound's level across each group: every bar reads as a fraction of it.
        bounds = [results[s.key][ORACLE_POLICY]["score_mean"] for s in scenarios]
        ax.hlines(bounds, x - 0.45, x + 0.45, colors="dimgray", linestyles=":", label="oracle")
    ax.set_xticks(x, [s.title for s in scenarios], fontsize=8)
    ax.set_ylabel("Average Reward Accumulated")
    # Above the axes: inside, it would cover the tallest bars or a ceiling.
    ax.legend(fontsize=7, ncol=len(policies) + 1, loc="lower center", bbox_to_anchor=(0.5, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


__all__ = [
    "BASELINE",
    "PAPER_BASELINE",
    "PAPER_RESULTS",
    "PAPER_SCENARIOS",
    "Cell",
    "Scenario",
    "evaluation_path",
    "fingerprint",
    "load_cached",
    "paired_ratio",
    "plot_scores",
    "policy_id",
    "policy_label",
    "results_markdown",
    "store",
    "table_cells",
]
