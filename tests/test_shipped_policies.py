"""The shipped policies: plain TorchScript, small, with a complete model card, usable by name."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

MODELS = Path(__file__).resolve().parents[1] / "models"
WILDFIRE = str(Path(sys.executable).with_name("wildfire"))
SCENARIOS = (
    "circular_2aircraft",
    "t_2aircraft",
    "arc_2aircraft",
    "circular_3aircraft",
    "circular_4aircraft",
)
POLICIES = {
    # policy name: (approach, scenarios its card holds test results for)
    "obs": ("obs", SCENARIOS),
    "belief": ("belief", SCENARIOS),
    "belief-radio": ("belief", (*SCENARIOS, "circular_2aircraft_commrange=300,loss=0.2")),
    "belief-camera": ("belief", ("circular_2aircraft", "circular_2aircraft_sensorcamera,p=0.1")),
    "belief-camera-radio": (
        "belief",
        (
            "circular_2aircraft_sensorcamera,p=0.1",
            "circular_2aircraft_commrange=300,loss=0.2_sensorcamera,p=0.1",
        ),
    ),
}


def policy_file(name: str) -> Path:
    return MODELS / f"{name.replace('-', '_')}_policy.pt"


@pytest.mark.parametrize("name", POLICIES)
def test_policy_loads_with_plain_torch_and_answers(name: str) -> None:
    approach = POLICIES[name][0]
    path = policy_file(name)
    assert path.stat().st_size < 5 * 2**20
    # No project import: what a user's own ROS 2 node would do.
    shape = (1, 1, 30, 40) if approach == "obs" else (1, 2, 100, 100)
    script = (
        "import json, sys, torch\n"
        "extra = {'wildfire_policy.json': ''}\n"
        f"m = torch.jit.load({str(path)!r}, _extra_files=extra)\n"
        f"q = m(torch.zeros({shape}), torch.zeros(1, 1, 5))\n"
        "card = json.loads(extra['wildfire_policy.json'])\n"
        "print(json.dumps({'shape': list(q.shape), 'card': card}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=True
    )
    answer = json.loads(done.stdout)
    assert answer["shape"] == [1, 1, 2]
    assert answer["card"] == json.loads(path.with_suffix(".json").read_text())


@pytest.mark.parametrize("name", POLICIES)
def test_model_card_says_how_it_was_trained_and_how_it_scores(name: str) -> None:
    approach, scenarios = POLICIES[name]
    card = json.loads(policy_file(name).with_suffix(".json").read_text())
    assert card["approach"] == approach
    for key in ("config", "iterations", "samples", "wall_time_s", "evaluation", "learning_curve"):
        assert card[key], key
    assert card["config"]["approach"] == approach
    for scenario in scenarios:
        result = card["test_evaluations"][scenario]
        assert result["episodes"] >= 20 and min(result["seeds"]) >= 2_000_000, scenario
        assert all(
            score <= ceiling
            for score, ceiling in zip(result["scores"], result["score_ceilings"], strict=True)
        ), scenario


@pytest.mark.parametrize("name", POLICIES)
def test_eval_flies_the_shipped_policy_by_name(name: str) -> None:
    done = subprocess.run(
        [WILDFIRE, "eval", "--policy", name, "--episodes", "1", "--duration", "5", "--json"],
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["policy"] == name
