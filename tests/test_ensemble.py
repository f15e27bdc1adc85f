"""``wildfire ensemble``: one policy file whose Q-values are the mean of its members'."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from wildfire_agent.policies import TorchScriptPolicy  # noqa: E402
from wildfire_learning.architectures import build_q_network  # noqa: E402
from wildfire_learning.checkpoint import load_policy_weights  # noqa: E402
from wildfire_learning.errors import LearningError  # noqa: E402
from wildfire_learning.export import export_policy  # noqa: E402
from wildfire_learning.train_config import TrainConfig  # noqa: E402

WILDFIRE = str(Path(sys.executable).with_name("wildfire"))


def member(tmp_path: Path, name: str, seed: int, approach: str = "belief") -> Path:
    torch.manual_seed(seed)
    arch = "lite" if approach == "belief" else "paper"
    card = {"approach": approach, "arch": arch, "iterations": 100 * seed, "wall_time_s": 1.5}
    return export_policy(build_q_network(approach, arch), tmp_path / f"{name}.pt", card)


def ensemble(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [WILDFIRE, "ensemble", *args], capture_output=True, text=True, timeout=120, check=False
    )


def test_the_ensemble_flies_the_mean_of_its_members_q_values(tmp_path: Path) -> None:
    members = [member(tmp_path, "a", 1), member(tmp_path, "b", 2), member(tmp_path, "c", 3)]
    out = tmp_path / "ensemble.pt"
    done = ensemble(*map(str, members), "--out", str(out), "--episodes", "0", "--json")
    assert done.returncode == 0, done.stderr
    policy = TorchScriptPolicy(out)
    rng = np.random.default_rng(0)
    images = rng.random((5, 2, 100, 100), dtype=np.float32)
    states = rng.standard_normal((5, 2, 5)).astype(np.float32)
    q = [TorchScriptPolicy(path).q_values(images, states) for path in members]
    np.testing.assert_allclose(policy.q_values(images, states), sum(q) / 3, rtol=1e-6)
    # Members that disagree: the ensemble's greedy action is the mean's, not any one member's.
    assert np.array_equal(policy.act(images, states), np.argmax(sum(q), axis=1))
    card = json.loads(out.with_suffix(".json").read_text())
    assert card == policy.card and card["approach"] == "belief"
    listed = card["ensemble"]["members"]
    assert [m["sha256"] for m in listed] == [
        hashlib.sha256(path.read_bytes()).hexdigest() for path in members
    ]
    assert card["iterations"] == 600 and card["wall_time_s"] == 4.5  # summed over members
    # A run cannot start from the mean of three networks: it names its members.
    with pytest.raises(LearningError, match="an ensemble of 3 networks"):
        config = TrainConfig(approach="belief", arch="lite")
        load_policy_weights(config.q_network(), out, config)


def test_the_card_records_the_paired_validation_against_each_member(tmp_path: Path) -> None:
    # Two runs' policies share a file name: the card tells them apart by their paths.
    (tmp_path / "run1").mkdir()
    (tmp_path / "run2").mkdir()
    members = [member(tmp_path / "run1", "a", 1), member(tmp_path / "run2", "a", 2)]
    out = tmp_path / "ensemble.pt"
    args = ("--episodes", "2", "--shapes", "arc", "--workers", "2", "--json")
    done = ensemble(*map(str, members), "--out", str(out), *args)
    assert done.returncode == 0, done.stderr
    selection = json.loads(done.stdout)["selection"]
    card = TorchScriptPolicy(out).card
    assert card["selection"] == selection and selection["validation_seeds"] == [1000000, 1000001]
    arc = selection["by_shape"]["arc"]
    assert card["evaluation"]["score_mean"] == arc["score_mean"]
    labels = [str(path) for path in members]
    assert [m["file"] for m in card["ensemble"]["members"]] == labels
    for name in labels:
        versus = arc["members"][name]
        assert versus["paired_gain"] == pytest.approx(arc["score_mean"] - versus["score_mean"])
        assert versus["wins"] + versus["losses"] <= 2


@pytest.mark.parametrize(
    ("members", "extra", "expected"),
    [
        (["a"], [], "expected at least 2 member policy files, got 1"),
        (["a", "obs"], [], "members must take the same inputs"),
        (["a", "missing"], [], "no such file"),
        (["a", "a"], ["--shapes", "blob"], "unknown fire shape 'blob'"),
    ],
)
def test_bad_members_get_one_line_and_exit_2(
    tmp_path: Path, members: list[str], extra: list[str], expected: str
) -> None:
    member(tmp_path, "a", 1)
    member(tmp_path, "obs", 2, approach="obs")
    files = [str(tmp_path / f"{name}.pt") for name in members]
    done = ensemble(*files, "--out", str(tmp_path / "e.pt"), *extra)
    assert done.returncode == 2
    assert expected in done.stderr and len(done.stderr.strip().splitlines()) == 1
    assert "Traceback" not in done.stderr
