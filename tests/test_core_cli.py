"""The `wildfire fire`, `eval` and `bench` commands, run as a user runs them."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

WILDFIRE = [str(Path(sys.executable).with_name("wildfire"))]


def run(*args: str, timeout: float = 240) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*WILDFIRE, *args], capture_output=True, text=True, timeout=timeout, check=False
    )


def test_fire_json_and_png(tmp_path):
    png = tmp_path / "fire.png"
    result = run(
        "fire",
        "--shape",
        "circular",
        "--wind",
        "0.5,0",
        "--steps",
        "30",
        "--seeds",
        "4",
        "--png",
        str(png),
        "--json",
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert len(summary["mean_burning"]) == 30 and len(summary["mean_affected"]) == 30
    assert summary["mean_affected"][-1] > summary["mean_affected"][0] > 0
    assert summary["mean_centroid_m"][0] > 520  # pushed east of the 505 m seed centre
    assert png.stat().st_size > 10_000


def test_eval_json(tmp_path):
    png = tmp_path / "episode.png"
    result = run(
        "eval",
        "--policy",
        "random",
        "--aircraft",
        "3",
        "--shape",
        "arc",
        "--episodes",
        "3",
        "--seed",
        "10",
        "--duration",
        "30",
        "--png",
        str(png),
        "--json",
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert len(summary["scores"]) == 3 and summary["seeds"] == [10, 11, 12]
    assert summary["score_mean"] == pytest.approx(sum(summary["scores"]) / 3)
    for key in ("score_sem", "belief_iou_mean", "mean_age_burning_s", "seconds_per_decision"):
        assert key in summary
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["fire", "--shape", "hexagon"], "unknown fire shape 'hexagon'"),
        (["fire", "--wind", "east"], "--wind"),
        (["fire", "--seeds", "-3"], "--seeds"),
        (["eval", "--policy", "genius"], "unknown policy 'genius'"),
        (["eval", "--policy", "/nonexistent/policy.pt"], "no such file"),
        (["eval", "--aircraft", "0"], "--aircraft"),
        (["eval", "--episodes", "-1"], "--episodes"),
        (["eval", "--policy", "rh", "--card"], "--card: policy rh has no model card"),
        (["eval", "--max-wind", "1.5"], "--max-wind"),
        (["run", "--wind", "0,0", "--max-wind", "0.4"], "not allowed with argument --wind"),
        (["eval", "--comm", "range=-3"], "range expected >= 0 m"),
        (["eval", "--comm", "loss=1.2"], "loss expected in [0, 1]"),
        (["report", "--comm", "power=5"], "keys range, loss, delay"),
        (["train", "--comm", "range=300,loss=x"], "--comm"),
        (["eval", "--sensor", "radar"], "--sensor"),
        (["eval", "--sensor", "camera", "--pixel-error", "0.5"], "[0, 0.5)"),
        (["eval", "--sensor", "camera", "--policy", "obs"], "takes obs images"),
        (["eval", "--sensor", "camera", "--wind-filter", "--comm", "range=300"], "--comm ideal"),
        (["run", "--wind-filter"], "wind filter: expected noisy reports"),
    ],
)
def test_bad_input_is_one_line_with_status_2(args, needle):
    result = run(*args, timeout=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], result.stderr
    assert "Traceback" not in result.stderr


def test_not_torchscript_policy_file(tmp_path):
    bogus = tmp_path / "policy.pt"
    bogus.write_text("not a model")
    result = run("eval", "--policy", str(bogus), "--episodes", "1", timeout=60)
    assert result.returncode == 2 and "not a TorchScript module" in result.stderr


def test_bench_core_suites_report_figures():
    result = run("bench", "--only", "fire", "rh", "--quick", "--json")
    assert result.returncode == 0, result.stderr
    figures = json.loads(result.stdout)
    assert figures["fire"]["fire_env_steps_per_s"] > figures["fire"]["fire_reference_steps_per_s"]
    assert figures["rh"]["rh_ms_per_decision"] > 0


def test_eval_card_records_the_result_in_both_copies_of_the_card(tmp_path):
    import torch

    from wildfire_agent.policies import TorchScriptPolicy
    from wildfire_learning.architectures import build_q_network
    from wildfire_learning.export import export_policy

    torch.manual_seed(0)
    policy = export_policy(build_q_network("obs"), tmp_path / "obs.pt", {"approach": "obs"})

    def eval_with_card(*wind: str) -> dict[str, Any]:
        quick = ("--shape", "t", "--aircraft", "3", "--episodes", "2", "--duration", "5")
        result = run("eval", "--policy", str(policy), *quick, *wind, "--card", "--json")
        assert result.returncode == 0, result.stderr
        return json.loads(result.stdout)

    summary = eval_with_card()
    sidecar = json.loads(policy.with_suffix(".json").read_text())
    recorded = sidecar["test_evaluations"]["t_3aircraft"]
    assert recorded["scores"] == summary["scores"] and recorded["seeds"] == [2_000_000, 2_000_001]
    assert TorchScriptPolicy(policy).card == sidecar

    # Another wind setting is recorded next to the default one, never over it.
    weaker = eval_with_card("--max-wind", "0.4")
    evaluations = json.loads(policy.with_suffix(".json").read_text())["test_evaluations"]
    assert evaluations["t_3aircraft"] == recorded
    assert evaluations["t_3aircraft_maxwind0.4"]["scores"] == weaker["scores"]
    # The same seeds draw the same winds, scaled to the smaller bound.
    assert np.allclose(np.array(weaker["winds"]), 0.5 * np.array(summary["winds"]))
