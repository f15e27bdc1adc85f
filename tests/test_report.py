"""``wildfire report``: the results table equals the evaluations it is made of, stored
evaluations are reused, and bad input is one line."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from wildfire_agent.policy_names import ORACLE_POLICY, SHIPPED_POLICIES
from wildfire_learning import results_report
from wildfire_learning.errors import LearningError
from wildfire_learning.evaluate import evaluate
from wildfire_learning.oracle_incumbents import INCUMBENT_POLICIES
from wildfire_learning.results_report import Scenario, results_markdown, table_cells
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig

WILDFIRE = [str(Path(sys.executable).with_name("wildfire"))]
QUICK = ("--episodes", "2", "--duration", "5")


def report(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*WILDFIRE, "report", *args], capture_output=True, text=True, timeout=300)


def quick_report(out: Path, policies: str, scenarios: str, seed: int = 40) -> dict[str, Any]:
    """JSON summary of a 2-episode, 5 s report (space-separated policies and scenarios)."""
    done = report(
        *("--policies", *policies.split(), "--scenarios", *scenarios.split()),
        *(*QUICK, "--seed", str(seed), "--out", str(out), "--json"),
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_report_tables_the_evaluations_and_reuses_them(tmp_path: Path) -> None:
    out = tmp_path / "report"
    summary = quick_report(out, "random rh", "circular:2")
    assert len(summary["evaluated"]) == 2 and summary["reused"] == 0

    config = EnvConfig(n_aircraft=2, max_duration_s=5.0)
    reference = {
        name: evaluate(make_vec_policy(name), config, [40, 41]).scores for name in ("random", "rh")
    }
    cells = summary["cells"]["circular_2aircraft"]
    assert cells["rh"]["mean"] == reference["rh"].mean()
    assert cells["random"]["mean"] == reference["random"].mean()
    assert cells["random"]["ratio"] == pytest.approx(
        reference["random"].mean() / reference["rh"].mean()
    )
    assert cells["rh"]["ratio"] is None
    markdown = (out / "results.md").read_text()
    assert "| circular, 2 aircraft |" in markdown and "receding horizon" in markdown
    assert (out / "scores.png").stat().st_size > 10_000

    # A second report with one more scenario flies only the new pairs.
    extended = quick_report(out, "random rh", "circular:2 arc:2")
    assert extended["reused"] == 2
    assert sorted(extended["evaluated"]) == [
        "random on arc, 2 aircraft",
        "receding horizon on arc, 2 aircraft",
    ]
    assert extended["cells"]["circular_2aircraft"] == cells
    # Other seeds are another experiment: nothing stored matches.
    assert quick_report(out, "random", "circular:2", seed=50)["reused"] == 0


def test_ratio_error_is_that_of_the_paired_difference() -> None:
    def result(scores: list[float]) -> dict[str, object]:
        return {
            "scores": scores,
            "score_mean": float(np.mean(scores)),
            "score_sem": float(np.std(scores, ddof=1) / np.sqrt(len(scores))),
            "ceiling_fraction": 0.5,
        }

    rh, dqn = result([100.0, 200.0, 300.0]), result([110.0, 230.0, 300.0])
    cells = table_cells({"circular_2aircraft": {"rh": rh, "obs": dqn}})["circular_2aircraft"]
    difference = np.array([10.0, 30.0, 0.0])
    assert cells["obs"].ratio == pytest.approx(640.0 / 600.0)
    # Far below the scores' own spread: the seeds are shared.
    assert cells["obs"].ratio_sem == pytest.approx(difference.std(ddof=1) / np.sqrt(3) / 200.0)
    assert cells["rh"].ratio is None and cells["rh"].ratio_sem is None
    assert cells["obs"].ratio_rh_paper is None  # no rh-paper in this row


def test_ratios_to_both_baselines_and_the_papers_to_rh_paper() -> None:
    def result(scores: list[float]) -> dict[str, object]:
        return {
            "scores": scores,
            "score_mean": float(np.mean(scores)),
            "score_sem": 1.0,
            "ceiling_fraction": 0.5,
            "score_ceiling_mean": 500.0,
        }

    results = {
        "circular_2aircraft": {
            "obs": result([220.0, 330.0]),
            "rh": result([200.0, 300.0]),
            "rh-paper": result([180.0, 270.0]),
        }
    }
    cells = table_cells(results)["circular_2aircraft"]
    assert cells["obs"].ratio == pytest.approx(550.0 / 500.0)
    assert cells["obs"].ratio_rh_paper == pytest.approx(550.0 / 450.0)
    assert cells["rh-paper"].ratio == pytest.approx(450.0 / 500.0)
    assert cells["rh"].ratio_rh_paper == pytest.approx(500.0 / 450.0)
    assert cells["rh-paper"].ratio_rh_paper is None
    markdown = results_markdown(
        results, [Scenario("circular", 2)], ["obs", "rh", "rh-paper"], "protocol"
    )
    # The paper's 3140.5 / 2725.6 beside ours to rh-paper, then ours to rh.
    row = next(line for line in markdown.splitlines()[-3:] if line.startswith("| circular"))
    assert row == "| circular, 2 aircraft | 1.15x | 1.16x | 1.22x +- 0.04 | - | 1.10x +- 0.02 | - |"


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--scenarios", "hexagon:2"], "hexagon"),
        (["--scenarios", "circular"], "expected SHAPE:N"),
        (["--scenarios", "circular:0"], "expected SHAPE:N"),
        (["--policies", "genius"], "unknown policy 'genius'"),
        (["--max-wind", "2"], "--max-wind"),
        (["--curves", "no-such-run"], "--curves no-such-run"),
    ],
)
def test_bad_input_is_one_line_with_status_2(tmp_path: Path, args: list[str], needle: str) -> None:
    result = report(*args, "--out", str(tmp_path / "r"))
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], result.stderr


def test_two_policies_of_one_name_are_refused(tmp_path: Path) -> None:
    shipped = Path(__file__).resolve().parents[1] / "models" / "obs_policy.pt"
    copies = []
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        copies.append(tmp_path / folder / "obs_policy.pt")
        shutil.copy(shipped, copies[-1])
    result = report("--policies", *map(str, copies), "--out", str(tmp_path / "r"))
    assert result.returncode == 2
    assert result.stderr.strip() == (
        "wildfire report: error: --policies: two policies are both named 'obs_policy'; rename one"
    )


def test_scenario_keys_match_the_model_cards() -> None:
    assert Scenario.parse("T:3").key == "t_3aircraft"
    assert Scenario.parse("circular:2").title == "circular, 2 aircraft"


def test_curves_are_the_mean_and_spread_across_runs(tmp_path: Path) -> None:
    # Two seeds' curves; only the iterations both evaluated at are drawn.
    header = "iteration,score_mean,score_sem,reward_mean\n"
    for name, rows in (
        ("seed1", "1000,100,9,-0.5\n2000,300,9,-0.4\n"),
        ("seed2", "2000,500,9,-0.2\n"),
    ):
        (tmp_path / name).mkdir()
        (tmp_path / name / "learning_curve.csv").write_text(header + rows)
    done = report(
        *("--curves", str(tmp_path / "seed1"), str(tmp_path / "seed2"), "--baseline", "350"),
        *("--out", str(tmp_path / "out"), "--json"),
    )
    assert done.returncode == 0, done.stderr
    (row,) = json.loads(done.stdout)["curve"]
    assert row["iteration"] == 2000 and row["runs"] == 2
    # Mean 400; sample standard deviation 141.4 over sqrt(2) runs: s.e. 100.
    assert row["score_mean"] == pytest.approx(400) and row["score_sem"] == pytest.approx(100)
    assert row["reward_mean"] == pytest.approx(-0.3) and row["reward_sem"] == pytest.approx(0.1)
    assert (tmp_path / "out" / "learning_curves.png").stat().st_size > 0


def test_report_gives_every_policy_as_a_fraction_of_the_oracle(tmp_path: Path) -> None:
    out = tmp_path / "report"
    summary = quick_report(out, "rh oracle", "circular:2")
    cells = summary["cells"]["circular_2aircraft"]
    assert cells["oracle"]["mean"] >= cells["rh"]["mean"]
    assert cells["rh"]["oracle_fraction"] == pytest.approx(
        cells["rh"]["mean"] / cells["oracle"]["mean"]
    )
    assert cells["oracle"]["oracle_fraction"] == 1.0
    markdown = (out / "results.md").read_text()
    assert f"{cells['rh']['oracle_fraction']:.0%} of oracle" in markdown


def test_an_oracle_result_is_keyed_by_its_incumbents_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The bound starts from the shipped networks' flights: retraining one makes its stored
    results stale, so the key changes with any of their files (and no other policy's does)."""
    files = {name: tmp_path / f"{name}.pt" for name in SHIPPED_POLICIES}
    for name, path in files.items():
        path.write_bytes(name.encode())
    monkeypatch.setattr(results_report, "resolve_policy_path", files.__getitem__)

    def key(policy: str) -> dict[str, Any]:
        return results_report.fingerprint(policy, None, [1, 2], 0.8, 400.0)

    before, planner = key(ORACLE_POLICY), key("rh")
    assert set(before["incumbents_sha256"]) == set(INCUMBENT_POLICIES) & set(SHIPPED_POLICIES)
    assert "incumbents_sha256" not in planner
    files["belief"].write_bytes(b"retrained")
    assert key(ORACLE_POLICY) != before
    assert key("rh") == planner


def test_field_scenarios_parse_and_fly(tmp_path: Path) -> None:
    """``field:`` and ``landcover:`` scenarios: their own map, seeded fires pre-burnt to an
    area, the generated CORINE raster; a bad one is one line."""
    field = Scenario.parse("field:500x500:ignitions=3:aircraft=8")
    assert field.key == "field500x500_ign3_8aircraft" and field.is_field
    config = field.config(EnvConfig(), tmp_path)
    assert config.geometry.shape == (500, 500) and config.n_aircraft == 8
    assert config.landscape is not None and config.landscape.ignitions == 3
    assert config.preburn_area_m2 == 300_000.0
    cover = Scenario.parse("landcover:300x300:ignitions=2:aircraft=4").config(EnvConfig(), tmp_path)
    assert cover.landscape is not None and cover.landscape.fuel is not None
    assert (cover.landscape.fuel.high == 0).any()  # the lake, the village, the road
    summary = evaluate(make_vec_policy("rh"), replace(cover, max_duration_s=10.0), [3])
    assert summary.to_json()["score_mean"] > 0
    for bad in ("field:500x500:aircraft=8", "field:10x10:ignitions=1:aircraft=1",
                "landcover:301x300:ignitions=1:aircraft=2"):  # fmt: skip
        with pytest.raises(LearningError, match="scenario"):
            Scenario.parse(bad)


def test_fleets_of_one_world_make_a_fleet_curve(tmp_path: Path) -> None:
    """Scenarios that differ only in their fleet form a series: a table by fleet size and
    ``fleet.png``; the ceiling is the fire's, the same for every fleet."""
    out = tmp_path / "report"
    worlds = "field:200x200:ignitions=2:aircraft=2 field:200x200:ignitions=2:aircraft=4"
    summary = quick_report(out, "random rh", worlds + " circular:2")
    assert str(out / "fleet.png") in summary["files"] and (out / "fleet.png").stat().st_size
    markdown = (out / "results.md").read_text()
    section = markdown.split("## Score against fleet size: field 200 x 200, 2 fires")[1]
    assert "| policy | 2 aircraft | 4 aircraft |" in section and "circular" not in section
    two, four = (summary["cells"][f"field200x200_ign2_{n}aircraft"]["rh"] for n in (2, 4))
    assert f"| receding horizon | {two['ceiling_fraction']:.0%} ({two['mean']:.0f})" in section
    assert four["ceiling_fraction"] >= 0
