"""``wildfire run`` end to end: one OS process per node, lockstep equality, recording,
failures, respawn and bad input (one line, exit 2, no process left behind)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig

pytestmark = [pytest.mark.dds, pytest.mark.timeout(180)]
WILDFIRE = [str(Path(sys.executable).parent / "wildfire")]


def children_of(pid: int) -> list[int]:
    """PIDs of the node processes a launcher started."""
    out = subprocess.run(
        ["ps", "-eww", "-o", "pid,ppid,args"], capture_output=True, text=True
    ).stdout
    rows = [line.split(None, 2) for line in out.splitlines()[1:]]
    nodes = ("_node", "wildfire_agent.agent_group")  # a lone node's module, composed agents'
    return [
        int(r[0])
        for r in rows
        if len(r) == 3 and int(r[1]) == pid and any(word in r[2] for word in nodes)
    ]


def alive(pids: list[int]) -> list[int]:
    out = subprocess.run(["ps", "-eww", "-o", "pid"], capture_output=True, text=True).stdout
    running = {int(x) for x in out.split()[1:]}
    return [p for p in pids if p in running]


def run_cli(
    args: list[str], env: dict[str, str], timeout: float = 150
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*WILDFIRE, *args], env=env, capture_output=True, text=True, timeout=timeout
    )


def run_logged(
    logs: Path, args: list[str], env: dict[str, str], timeout: float = 150
) -> subprocess.CompletedProcess[str]:
    """``run_cli`` of a ``wildfire run`` that keeps its nodes' logs in ``logs``; a run that
    hangs fails with the end of every node's log (where each one stopped)."""
    try:
        return run_cli([*args, "--log-dir", str(logs)], env, timeout)
    except subprocess.TimeoutExpired as error:
        tails = [
            f"--- {log.name}:\n" + "\n".join(log.read_text().splitlines()[-5:])
            for log in sorted(logs.glob("*.log"))
        ]
        raise AssertionError(f"{error}\n" + "\n".join(tails)) from None


@pytest.fixture(scope="module")
def obs_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    import torch

    from wildfire_agent.policies import save_policy_card
    from wildfire_learning.q_network import QNetwork

    torch.manual_seed(0)
    path = tmp_path_factory.mktemp("policy") / "obs_policy.pt"
    module = torch.jit.script(QNetwork((1, 30, 40)).eval())
    torch.jit.save(module, str(path), _extra_files=save_policy_card({"approach": "obs"}))
    return path


def fly_and_compare_with_evaluate(
    tmp_path: Path, env: dict[str, str], name: str, n: int, duration: float, extra: list[str]
) -> dict[str, object]:
    """``wildfire run --fast`` (recorded, seed 5) equals ``wildfire eval``: score, ceiling,
    decisions and every exact state of the bag; its summary."""
    from wildfire_msgs_py.codecs import score_from_msg
    from wildfire_msgs_py.system_codecs import stamped_state_from_msg
    from wildfire_ros.bag import read_messages

    seed = 5
    bag = tmp_path / "bag"
    logs = tmp_path / "logs"
    result = run_logged(
        logs,
        [
            "run",
            "--aircraft",
            str(n),
            "--policy",
            name,
            "--seed",
            str(seed),
            "--duration",
            str(duration),
            "--fast",
            "--json",
            "--record",
            str(bag),
            "--wind",
            "0.3,-0.2",
            *extra,
        ],
        env,
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    config = EnvConfig(
        n_aircraft=n, shapes=("circular",), wind=(0.3, -0.2), max_duration_s=duration
    )
    reference = evaluate(make_vec_policy(name), config, [seed], record=True).episodes[0]
    assert summary["score"] == reference.score
    assert summary["score_ceiling"] == reference.score_ceiling
    assert summary["decisions"] == reference.decisions
    assert summary["trajectory_points"] == reference.trajectory.shape[0]

    # The recording holds every exact state: the flight paths equal the environment's.
    states: dict[str, dict[int, np.ndarray]] = {}
    scores = []
    for message in read_messages(
        bag, topics=[f"/uav{k}/state_stamped" for k in range(n)] + ["/wildfire/score"]
    ):
        if message.topic == "/wildfire/score":
            scores.append(score_from_msg(message.message))
            continue
        stamp, vector = stamped_state_from_msg(message.message)
        states.setdefault(message.topic, {})[stamp] = vector
    for k in range(n):
        recorded = states[f"/uav{k}/state_stamped"]
        path = np.array([recorded[t][:2] for t in sorted(recorded)])
        assert np.array_equal(path, reference.trajectory[:, k])
    assert scores[-1] == reference.score
    return dict(summary)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("policy", "n", "duration"),
    [
        ("rh", 3, 30.0),
        ("rh-paper", 3, 20.0),
        ("random", 2, 30.0),
        ("obs", 2, 20.0),
    ],
)
def test_lockstep_run_equals_evaluate(
    tmp_path: Path, dds_env: dict[str, str], obs_policy: Path, policy: str, n: int, duration: float
) -> None:
    name = str(obs_policy) if policy == "obs" else policy
    png = tmp_path / "r.png"
    fly_and_compare_with_evaluate(tmp_path, dds_env, name, n, duration, ["--png", str(png)])
    assert png.stat().st_size > 10_000


def test_composed_agents_run_equals_evaluate(tmp_path: Path, dds_env: dict[str, str]) -> None:
    """Two agent nodes in one process (``agent_group``), one alone: the same flight as eval."""
    summary = fly_and_compare_with_evaluate(
        tmp_path, dds_env, "rh", 3, 10.0, ["--agents-per-process", "2"]
    )
    assert summary["composed_agents"] == {"agents0": ["uav0", "uav1"]}
    # Where the ticks' wall time went, as the barrier saw it (wildfire_sim.tick_split).
    split = summary["tick_split_ms"]
    assert split["ticks"] == summary["decisions"] + 1  # ticks 0..N, each closed
    assert set(split) == {"ticks", "fire", "nodes", "agents", "belief_aggregator", "wildfire_run"}
    assert 0 < split["agents"] <= split["nodes"] and split["fire"] >= 0
    logs = tmp_path / "logs"
    assert sorted(log.name for log in logs.glob("*.log")) == [
        "agents0.log",
        "belief_aggregator.log",
        "fire_simulator.log",
        "uav2.log",
    ]
    composed = (logs / "agents0.log").read_text()
    assert "uav0: policy rh (lockstep)" in composed and "uav1: policy rh (lockstep)" in composed


def test_realtime_smoke(tmp_path: Path, dds_env: dict[str, str]) -> None:
    result = run_cli(
        [
            "run",
            "--aircraft",
            "2",
            "--policy",
            "rh",
            "--duration",
            "4",
            "--realtime",
            "--json",
            "--seed",
            "2",
        ],
        dds_env,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["mode"] == "realtime" and summary["decisions"] == 40
    assert summary["deadlines"]["uav0"]["decisions"] >= 20
    assert 3.5 < summary["wall_time_s"] < 30


def _start_run(
    tmp_path: Path, env: dict[str, str], extra: list[str]
) -> tuple[subprocess.Popen[str], Path]:
    logs = tmp_path / "logs"
    process = subprocess.Popen(
        [*WILDFIRE, "run", "--aircraft", "2", "--policy", "random", "--log-dir", str(logs), *extra],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    return process, logs


def _stop(process: subprocess.Popen[str]) -> None:
    """Stop a launcher like Ctrl-C would (it then stops its nodes)."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()


def _wait_for_line(log: Path, text: str, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if log.exists() and text in log.read_text():
            return
        time.sleep(0.2)
    raise AssertionError(f"{log.name}: no {text!r} within {timeout:.0f} s")


def _pid_of(launcher: int, logs: Path, node: str, timeout: float = 20.0) -> int:
    """PID of a node started by the launcher ``launcher`` (found by its log file and its
    command line among the launcher's children: another run may be flying beside this one)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        out = subprocess.run(
            ["ps", "-eww", "-o", "pid,ppid,args"], capture_output=True, text=True
        ).stdout
        if (logs / f"{node}.log").exists():
            for line in out.splitlines():
                pid, parent, args = [*line.split(None, 2), "", ""][:3]
                if parent != str(launcher):
                    continue
                if node == "uav1" and "agent_node" in args and "__ns:=/uav1" in args:
                    return int(pid)
                if node == "belief_aggregator" and "belief_aggregator_node" in args:
                    return int(pid)
        time.sleep(0.2)
    raise AssertionError(f"{node} did not start")


def test_killed_node_is_named_and_the_bag_is_finalized(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    from wildfire_ros.bag import bag_info

    bag = tmp_path / "bag"
    process, logs = _start_run(
        tmp_path, dds_env, ["--realtime", "--duration", "60", "--record", str(bag)]
    )
    try:
        pid = _pid_of(process.pid, logs, "uav1")
        time.sleep(2.0)
        nodes = children_of(process.pid)
        assert len(nodes) == 4
        os.kill(pid, signal.SIGKILL)
        _, stderr = process.communicate(timeout=30)
    finally:
        _stop(process)
    assert process.returncode == 2
    assert "node uav1 died (signal 9)" in stderr and len(stderr.strip().splitlines()) == 1
    assert bag_info(bag).message_count > 0
    assert alive(nodes) == []


def test_killed_composed_process_names_all_its_nodes(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    """SIGKILL of the one process carrying both agents: the failure names both nodes."""
    process, logs = _start_run(
        tmp_path, dds_env, ["--realtime", "--duration", "60", "--agents-per-process", "2"]
    )
    try:
        _wait_for_line(logs / "agents0.log", "uav1: policy random")
        _wait_for_line(logs / "agents0.log", "uav0: policy random")
        nodes = children_of(process.pid)
        groups = [pid for pid in nodes if "wildfire_agent.agent_group" in _args_of(pid)]
        assert len(nodes) == 3 and len(groups) == 1, [_args_of(pid) for pid in nodes]
        time.sleep(1.0)
        os.kill(groups[0], signal.SIGKILL)
        _, stderr = process.communicate(timeout=30)
    finally:
        _stop(process)
    assert process.returncode == 2
    assert "nodes uav0, uav1 (process agents0) died (signal 9)" in stderr, stderr
    assert len(stderr.strip().splitlines()) == 1
    assert alive(nodes) == []


def _args_of(pid: int) -> str:
    return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()


@pytest.mark.slow
def test_respawned_nodes_carry_on(tmp_path: Path, dds_env: dict[str, str]) -> None:
    from wildfire_msgs_py.codecs import score_from_msg, time_from_msg
    from wildfire_ros.bag import read_messages

    bag = tmp_path / "bag"
    process, logs = _start_run(
        tmp_path,
        dds_env,
        ["--realtime", "--respawn", "--duration", "20", "--json", "--record", str(bag)],
    )
    try:
        # Mid-flight: the shared belief the new aggregator must take over is 3 s old.
        _wait_for_line(logs / "fire_simulator.log", "every reporter is ready")
        time.sleep(3.0)
        os.kill(_pid_of(process.pid, logs, "uav1"), signal.SIGKILL)
        os.kill(_pid_of(process.pid, logs, "belief_aggregator"), signal.SIGKILL)
        killed_ns = time.time_ns()
        stdout, stderr = process.communicate(timeout=60)
    finally:
        _stop(process)
    assert process.returncode == 0, stderr
    summary = json.loads(stdout)
    assert summary["respawns"] == {"uav1": 1, "belief_aggregator": 1}
    assert "respawning" in stderr
    # The new aggregator took the shared belief (and score) over from the agents' copies ...
    assert "recovered the shared belief of t =" in (logs / "belief_aggregator.log").read_text()
    scores, uav1_stamps = [], []
    for message in read_messages(bag, topics=["/wildfire/score", "/uav1/state_stamped"]):
        if message.topic == "/wildfire/score":
            scores.append(score_from_msg(message.message))
        else:
            uav1_stamps.append(time_from_msg(message.message.header.stamp))
    # ... so the team score never fell back to zero, and the recording holds the whole run:
    # the killed nodes' messages before the kill and the respawned ones' after it.
    assert scores == sorted(scores) and scores[-1] > 0
    assert min(uav1_stamps) < killed_ns < max(uav1_stamps)


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--policy", "nonsense"], "--policy 'nonsense'"),
        (["--policy", "missing.pt"], "missing.pt: no such file"),
        (["--aircraft", "0"], "expected a number >= 1"),
        (["--agents-per-process", "0"], "argument --agents-per-process: expected a number >= 1"),
        (["--wind", "0.5"], "expected WX,WY"),
        (["--record", "/proc/forbidden/bag"], "--record /proc/forbidden/bag"),
    ],
)
def test_bad_input_is_one_line(args: list[str], expected: str, dds_env: dict[str, str]) -> None:
    result = run_cli(["run", "--duration", "5", *args], dds_env, timeout=60)
    assert result.returncode == 2
    assert expected in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_bad_params_file(tmp_path: Path, dds_env: dict[str, str]) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("fire_simulator: {ros__parameters: [1, 2\n")
    result = run_cli(["run", "--duration", "5", "--params-file", str(bad)], dds_env, timeout=60)
    assert result.returncode == 2 and "malformed YAML" in result.stderr
    unknown = tmp_path / "unknown.yaml"
    unknown.write_text("/fire_simulator:\n  ros__parameters:\n    sed: 3\n")
    result = run_cli(
        [
            "run",
            "--duration",
            "5",
            "--params-file",
            str(unknown),
            "--log-dir",
            str(tmp_path / "logs"),
        ],
        dds_env,
        timeout=60,
    )
    assert result.returncode == 2
    assert "node fire_simulator died (exit status 2)" in result.stderr
    assert "unknown parameter 'sed'" in result.stderr


def test_node_rejects_out_of_range_parameter_and_bad_policy(dds_env: dict[str, str]) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "wildfire_agent.agent_node", "--ros-args", "-p", "n_aircraft:=0"],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2 and "out of range" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    result = subprocess.run(
        [sys.executable, "-m", "wildfire_agent.agent_node", "--ros-args", "-p", "policy:=/nope.pt"],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2 and "/nope.pt: no such file" in result.stderr
