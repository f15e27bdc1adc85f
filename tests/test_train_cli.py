"""``wildfire train`` end to end with tiny budgets: both approaches, resume, export, bad input."""

from __future__ import annotations

import csv
import json
import signal
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from tensorboardX.proto import event_pb2

from wildfire_cli import main as cli_main
from wildfire_learning.architectures import build_q_network
from wildfire_learning.checkpoint import CHECKPOINT_FILE, load_checkpoint
from wildfire_learning.plots import CURVE_CSV, CURVE_PNG
from wildfire_learning.scalar_log import log_dir

WILDFIRE = str(Path(sys.executable).with_name("wildfire"))
# Seconds-long runs: few envs, a small replay, short episodes, one evaluation episode.
TINY = [
    "--num-envs",
    "2",
    "--buffer-size",
    "400",
    "--learning-starts",
    "100",
    "--eval-episodes",
    "1",
    "--episode-seconds",
    "4",
    "--target-network-frequency",
    "3",
]


def wildfire_train(*args: str, timeout: float = 150) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [WILDFIRE, "train", *args], capture_output=True, text=True, timeout=timeout, check=False
    )


def run_json(*args: str) -> dict:
    done = wildfire_train(*args, "--json")
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize(
    ("approach", "extra"),
    [
        ("obs", ["--iterations", "12"]),
        ("belief", ["--iterations", "3", "--batch-size", "4", "--arch", "paper"]),
        ("obs", ["--iterations", "3", "--dueling"]),
        ("obs", ["--iterations", "3", "--prioritized"]),
    ],
)
def test_train_smoke_writes_policy_curve_and_checkpoint(
    tmp_path: Path, approach: str, extra: list[str]
) -> None:
    run_dir = tmp_path / "run"
    policy = run_dir / f"{approach}_policy.pt"
    summary = run_json(
        *("--approach", approach, *TINY, *extra, "--baseline", "123.5"),
        # --out inside the --run-dir that the run creates.
        *("--run-dir", str(run_dir), "--out", str(policy)),
    )
    iterations = int(extra[1])
    assert summary["iterations"] == iterations
    # One iteration per 10 samples after the 100-sample prefill (a step adds 4 samples).
    assert 100 + 10 * (iterations - 1) < summary["samples"] <= 100 + 10 * iterations + 4 + 100
    assert summary["receding_horizon_score"] == 123.5
    card = json.loads(policy.with_suffix(".json").read_text())
    assert card["approach"] == approach and card["iterations"] == iterations
    assert card["evaluation"]["episodes"] == 1
    assert card["config"]["dueling"] == ("--dueling" in extra)
    # Prioritised replay gave the replayed transitions their Bellman errors as priorities.
    with np.load(run_dir / "replay.npz") as replay:
        assert (replay["priorities"] != 1.0).any() == ("--prioritized" in extra)
    for name in (CHECKPOINT_FILE, CURVE_CSV, CURVE_PNG, "replay.npz"):
        assert (run_dir / name).is_file(), name
    rows = list(csv.DictReader((run_dir / CURVE_CSV).read_text().splitlines()))
    assert rows[0]["iteration"] == str(iterations)
    # The value check has columns; these episodes are cut long before the discount fades, so
    # no decision's return is known (validation.value_check, tested on its own).
    assert rows[0]["q_predicted"] == rows[0]["q_collected"] == "nan"
    assert float(rows[0]["reward_mean"]) == float(rows[0]["reward_mean"])  # a number, not nan


def tensorboard_scalars(folder: Path) -> dict[str, list[tuple[int, float]]]:
    """Every scalar of the TensorBoard event files in ``folder``, by tag, in file order.

    Read without TensorBoard: an event file is TFRecords (length, its CRC, an ``Event``
    protobuf, its CRC), the format ``tensorboardX`` writes."""
    scalars: dict[str, list[tuple[int, float]]] = {}
    for path in sorted(folder.glob("events.out.tfevents.*")):
        data, at = path.read_bytes(), 0
        while at < len(data):
            (length,) = struct.unpack("<Q", data[at : at + 8])
            event = event_pb2.Event.FromString(data[at + 12 : at + 12 + length])
            at += 12 + length + 4
            for value in event.summary.value:
                scalars.setdefault(value.tag, []).append((event.step, value.simple_value))
    return scalars


def test_resume_continues_counters_and_export_matches_module(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    first = run_json(
        "--approach",
        "obs",
        *TINY,
        "--iterations",
        "6",
        "--eval-every",
        "3",
        "--run-dir",
        str(run_dir),
    )
    before = load_checkpoint(run_dir)
    second = run_json("--resume", "--run-dir", str(run_dir), "--iterations", "10")
    assert second["iterations"] == 10
    assert second["samples"] > first["samples"] and second["episodes"] > first["episodes"]
    assert [r["iteration"] for r in second["learning_curve"]] == [3, 6, 9, 10]
    after = load_checkpoint(run_dir)
    # The resumed run kept its saved settings and went on training the saved weights.
    assert after["config"]["num_envs"] == 2 and after["config"]["buffer_size"] == 400
    assert after["state"]["iterations"] == 10 and before["state"]["iterations"] == 6
    weights = "head.4.weight"
    assert not torch.equal(before["q_network"][weights], after["q_network"][weights])

    # Both sessions logged every evaluation to TensorBoard, at its sample count.
    scores = tensorboard_scalars(log_dir(run_dir))["eval/score"]
    curve = after["state"]["curve"]
    assert scores == [(r["samples"], pytest.approx(r["score_mean"])) for r in curve]

    # Every evaluation exported the network; the best-scoring one is kept too.
    best = json.loads((run_dir / "best_obs_policy.json").read_text())
    assert best["evaluation"]["score_mean"] == max(
        r["score_mean"] for r in second["learning_curve"]
    )

    # The export opens with plain torch (no project module imported) ...
    policy = run_dir / "obs_policy.pt"
    images = (np.random.default_rng(0).random((3, 1, 30, 40)) < 0.3).astype(np.float32)
    states = np.random.default_rng(1).standard_normal((3, 1, 5)).astype(np.float32)
    np.save(tmp_path / "images.npy", images)
    np.save(tmp_path / "states.npy", states)
    script = (
        "import sys, json, numpy as np, torch\n"
        f"files = {{'wildfire_policy.json': ''}}\n"
        f"m = torch.jit.load({str(policy)!r}, _extra_files=files)\n"
        f"q = m(torch.from_numpy(np.load({str(tmp_path / 'images.npy')!r})),"
        f" torch.from_numpy(np.load({str(tmp_path / 'states.npy')!r})))\n"
        "assert not [k for k in sys.modules if k.startswith('wildfire')]\n"
        "print(json.dumps({'q': q.tolist(), 'card': json.loads(files['wildfire_policy.json'])}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-I", "-c", script],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    loaded = json.loads(done.stdout)
    assert loaded["card"]["approach"] == "obs" and loaded["card"]["iterations"] == 10
    # ... and gives the Q-values of the trained module.
    module = build_q_network("obs")
    module.load_state_dict(after["q_network"])
    with torch.inference_mode():
        expected = module.eval()(torch.from_numpy(images), torch.from_numpy(states))
    np.testing.assert_allclose(np.array(loaded["q"]), expected.numpy(), rtol=1e-5, atol=1e-6)


def test_help_lists_every_hyperparameter() -> None:
    done = wildfire_train("--help", timeout=60)
    assert done.returncode == 0, done.stderr
    for option in (
        "--total-samples",
        "--iterations",
        "--num-envs",
        "--lr",
        "--buffer-size",
        "--learning-starts",
        "--train-frequency",
        "--exploration-samples",
        "--target-network-frequency",
        "--from-bag",
        "--resume",
        "--baseline",
    ):
        assert option in done.stdout, option


def test_bad_inputs_are_one_line_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run_dir = tmp_path / "run"
    run_json("--approach", "obs", *TINY, "--iterations", "2", "--run-dir", str(run_dir))
    cases = [
        (["--resume", "--run-dir", str(run_dir), "--approach", "belief"], "incompatible"),
        (["--resume", "--run-dir", str(tmp_path / "none")], "no checkpoint"),
        (["--approach", "obs", "--run-dir", str(run_dir)], "holds a run already"),
        (["--approach", "obs", "--from-bag", str(tmp_path)], "--iterations"),
        (["--approach", "obs", "--shapes", "hexagon", "--run-dir", str(tmp_path / "x")], "hexagon"),
        (["--approach", "obs", "--arch", "fast", "--run-dir", str(tmp_path / "y")], "fast"),
        (["--baseline", "nothing.json", "--run-dir", str(tmp_path / "z")], "--baseline"),
        (["--lr", "-1"], "expected a number > 0"),
        # --out creates missing folders (as mkdir -p), but not through a file.
        (
            ["--out", str(tmp_path / "a_file" / "p.pt"), "--run-dir", str(tmp_path / "t")],
            "cannot create",
        ),
        (
            [
                "--approach",
                "belief",
                "--init-from",
                str(run_dir / "obs_policy.pt"),
                "--run-dir",
                str(tmp_path / "w"),
            ],
            "a obs/paper policy, this run trains belief",
        ),
        (
            [
                "--dueling",
                "--init-from",
                str(run_dir / "obs_policy.pt"),
                "--run-dir",
                str(tmp_path / "u"),
            ],
            "a obs/paper policy, this run trains obs/paper+dueling",
        ),
        (["--resume", "--run-dir", str(run_dir), "--dueling"], "asked obs/paper+dueling"),
        (["--reward", "score"], "--reward"),
        (["--time-limit", "0"], "expected a number > 0"),
        (
            [
                *("--reward", "belief", "--from-bag", str(tmp_path), "--iterations", "2"),
                *("--run-dir", str(tmp_path / "r")),
            ],
            "expected --reward approach, got belief",
        ),
        (
            [
                "--approach",
                "obs",
                "--init-from",
                str(tmp_path / "none.pt"),
                "--run-dir",
                str(tmp_path / "v"),
            ],
            "no such file",
        ),
    ]
    (tmp_path / "a_file").write_text("not a folder")
    (tmp_path / "corrupt").mkdir()
    (tmp_path / "corrupt" / CHECKPOINT_FILE).write_bytes(b"\x00garbage")
    cases.append((["--resume", "--run-dir", str(tmp_path / "corrupt")], "unreadable"))
    # In-process (the CLI's own main): these fail before training anything.
    for args, expected in cases:
        try:
            status = cli_main(["train", *args])
        except SystemExit as stop:  # argparse rejects values itself
            status = stop.code
        assert status == 2, args
        message = capsys.readouterr().err.strip()
        assert "\n" not in message and "Traceback" not in message, message
        assert expected in message, (args, message)


def test_interrupted_run_checkpoints_and_resumes(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    process = subprocess.Popen(
        [
            WILDFIRE,
            "train",
            "--approach",
            "obs",
            *TINY,
            "--iterations",
            "100000",
            "--run-dir",
            str(run_dir),
            "--log-every",
            "0.2",
        ],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert process.stderr is not None
        for line in process.stderr:  # status lines: wait until it trains
            if "training: iteration" in line and " iteration 0/" not in line:
                break
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=60) == 130
    finally:
        if process.poll() is None:
            process.kill()
    saved = load_checkpoint(run_dir)["state"]["iterations"]
    assert 0 < saved < 100000
    resumed = run_json("--resume", "--run-dir", str(run_dir), "--iterations", str(saved + 2))
    assert resumed["iterations"] == saved + 2


def test_time_limit_ends_learning_then_evaluates_exports_and_resumes(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    limited = run_json(
        *("--approach", "obs", *TINY, "--iterations", "100000", "--time-limit", "6"),
        *("--run-dir", str(run_dir)),
    )
    done = limited["iterations"]
    assert done < 100000  # stopped by the clock, not by the target
    # ... and then finished as a run does: evaluated at the iteration it reached, checkpointed
    # and exported with a card that says where it stopped.
    assert [r["iteration"] for r in limited["learning_curve"]] == [done]
    assert load_checkpoint(run_dir)["state"]["iterations"] == done
    assert json.loads((run_dir / "obs_policy.json").read_text())["iterations"] == done
    resumed = run_json("--resume", "--run-dir", str(run_dir), "--iterations", str(done + 2))
    assert resumed["iterations"] == done + 2


def test_a_stop_signal_inside_a_compiled_kernel_still_checkpoints(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A stop signal whose handler runs inside a numba kernel's call (the kernel boxes its
    result in Python) surfaces as ``SystemError`` caused by the ``KeyboardInterrupt``, as it
    did in an oracle-taught run. The run must save and stop as it does for Ctrl-C."""
    from wildfire_learning import dqn

    calls = 0
    act = dqn.greedy_actions

    def interrupted_in_a_kernel(*args: object, **kwargs: object) -> np.ndarray:
        nonlocal calls
        calls += 1
        if calls == 4:
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as interrupt:
                raise SystemError(
                    "CPUDispatcher(<function search>) returned a result with an exception set"
                ) from interrupt
        return act(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(dqn, "greedy_actions", interrupted_in_a_kernel)
    run_dir = tmp_path / "run"
    args = ["--approach", "obs", *TINY, "--iterations", "1000", "--run-dir", str(run_dir)]
    assert cli_main(["train", *args, "--json"]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert load_checkpoint(run_dir)["state"]["iterations"] > 0


def test_a_resumed_run_keeps_the_behaviour_it_was_started_with() -> None:
    import argparse
    from dataclasses import fields

    from wildfire_cli.train import build_config
    from wildfire_learning.train_config import TrainConfig

    nothing_given = argparse.Namespace(**{f.name: None for f in fields(TrainConfig)})
    fresh = build_config(nothing_given, None)
    assert (fresh.n_step, fresh.explore_hold, fresh.double_q) == (20, 20, True)
    # A checkpoint written before n-step, reward scaling, held exploration and double DQN.
    old = build_config(nothing_given, {"approach": "obs", "learning_rate": 1e-4})
    assert (old.n_step, old.reward_scale, old.explore_hold, old.double_q) == (1, 1.0, 1, False)
    assert old.learning_rate == 1e-4


def test_init_from_starts_at_the_policy_weights_and_says_so(tmp_path: Path) -> None:
    first = tmp_path / "first"
    run_json("--approach", "obs", *TINY, "--iterations", "3", "--run-dir", str(first))
    start = torch.jit.load(str(first / "obs_policy.pt")).state_dict()
    second = tmp_path / "second"
    run_json(
        "--approach",
        "obs",
        *TINY,
        "--iterations",
        "1",
        "--run-dir",
        str(second),
        "--init-from",
        str(first / "obs_policy.pt"),
    )
    tuned = torch.jit.load(str(second / "obs_policy.pt")).state_dict()
    # One AdaMax step moves a weight by at most about the learning rate.
    assert max(float((tuned[k] - start[k]).abs().max()) for k in start) < 1e-3
    card = json.loads((second / "obs_policy.json").read_text())
    assert card["initialised_from"]["iterations"] == 3
    # Resuming the fine-tuning run keeps its lineage in the card.
    run_json("--resume", "--run-dir", str(second), "--iterations", "2")
    resumed = json.loads((second / "obs_policy.json").read_text())
    assert resumed["iterations"] == 2
    assert resumed["initialised_from"] == card["initialised_from"]


def test_reward_option_trains_the_observation_network_on_the_team_reward() -> None:
    from wildfire_agent.approaches import belief_rewards
    from wildfire_learning.train_config import TrainConfig
    from wildfire_world.env import WildfireVecEnv

    own = TrainConfig(approach="obs").env_config()
    team = TrainConfig(approach="obs", reward="belief").env_config()
    assert (own.observation, own.reward) == ("obs", "obs")
    assert (team.observation, team.reward) == ("obs", "belief")
    envs = [WildfireVecEnv(config, 2) for config in (own, team)]
    for env in envs:
        env.reset([5, 6])
    rng = np.random.default_rng(0)
    seen = 0.0
    for _ in range(60):
        actions = rng.integers(0, 2, size=(2, 2))
        mine, ours = (env.step(actions) for env in envs)
        # The same flight and images; only the reward differs: the team's new cells, shared,
        # less the proximity penalty.
        np.testing.assert_array_equal(mine.observations["image"], ours.observations["image"])
        np.testing.assert_array_equal(mine.team_reward, ours.team_reward)
        expected = belief_rewards(
            ours.team_reward, envs[1].aircraft, team.obs_weights, team.belief_proximity_weight
        )
        np.testing.assert_allclose(ours.rewards, expected)
        seen += float(ours.team_reward.sum())
    assert seen > 0
