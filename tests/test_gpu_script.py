"""``scripts/gpu_train.sh``, the full-resolution belief run prepared for a borrowed GPU machine,
on its CPU path: that machine has torch and the scientific stack but no ROS packages, so the
script runs here with them hidden, and with tiny options it trains, evaluates and exports."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "gpu_train.sh"
# What a machine without ROS lacks: importing any of them fails, as it would there.
HIDDEN = ("rclpy", "cyclonedds", "rosbags", "mcap", "ray")
TINY = (
    *("--num-envs", "2", "--buffer-size", "400", "--learning-starts", "100"),
    *("--eval-episodes", "1", "--episode-seconds", "4"),
)


def _run(tmp_path: Path, **env: str) -> subprocess.CompletedProcess[str]:
    blocker = tmp_path / "no_ros"
    blocker.mkdir(exist_ok=True)
    (blocker / "sitecustomize.py").write_text(
        "import sys\n" + "".join(f"sys.modules[{name!r}] = None\n" for name in HIDDEN)
    )
    return subprocess.run(
        ["bash", str(SCRIPT), *TINY],
        env={
            **os.environ,
            "DEVICE": "cpu",
            "PYTHON": sys.executable,
            "PYTHONPATH": str(blocker),
            "OUT": str(tmp_path / "out"),
            "RUN_DIR": str(tmp_path / "run"),
            **env,
        },
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_gpu_script_trains_the_full_resolution_network_without_ros(tmp_path: Path) -> None:
    done = _run(tmp_path, ITERATIONS="2")
    assert done.returncode == 0, done.stderr
    out = tmp_path / "out"
    summary = json.loads((out / "train.json").read_text())
    assert (summary["approach"], summary["arch"], summary["iterations"]) == ("belief", "paper", 2)
    assert summary["iterations_per_s"] > 0
    assert summary["learning_curve"][-1]["iteration"] == 2
    # The exported network is the full-resolution one (~19 MB): it comes back in parts.
    parts = sorted(out.glob("belief_policy.pt.part-*"))
    assert len(parts) == 2 and not (out / "belief_policy.pt").exists()
    whole = tmp_path / "belief_policy.pt"
    whole.write_bytes(b"".join(part.read_bytes() for part in parts))
    module = torch.jit.load(str(whole))
    q = module(
        torch.zeros(1, *json.loads((out / "belief_policy.json").read_text())["image_shape"]),
        torch.zeros(1, 1, 5),
    )
    assert q.shape == (1, 1, 2)
