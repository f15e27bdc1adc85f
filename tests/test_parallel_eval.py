"""Evaluation over local processes and on Ray equals the serial evaluation bit for bit; the
device option never assumes CUDA; bad addresses and devices are one line with status 2."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import torch

from wildfire_learning.evaluate import EvaluationSummary, evaluate
from wildfire_learning.parallel import EvalJob, evaluate_jobs, split_seeds
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig

WILDFIRE = [str(Path(sys.executable).with_name("wildfire"))]
TIMINGS = {"seconds_per_decision", "wall_time_s", "planning_s"}
"""The only fields of an evaluation that may differ between two runs of it."""


def wildfire(*args: str, timeout: float = 600) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*WILDFIRE, *args], capture_output=True, text=True, timeout=timeout)


def without_timings(result: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in result.items() if k not in TIMINGS}


def assert_same_episodes(a: EvaluationSummary, b: EvaluationSummary) -> None:
    assert without_timings(a.to_json()) == without_timings(b.to_json())
    for x, y in zip(a.episodes, b.episodes, strict=True):
        if x.trajectory is not None and y.trajectory is not None:
            assert x.trajectory.tobytes() == y.trajectory.tobytes()


def test_seeds_are_split_in_order_into_near_equal_runs() -> None:
    assert split_seeds([1, 2, 3, 4, 5], 2) == [(1, 2, 3), (4, 5)]
    assert split_seeds([7], 4) == [(7,)]
    assert [s for run in split_seeds(list(range(20)), 3) for s in run] == list(range(20))


@pytest.mark.slow
def test_two_local_workers_fly_the_serial_episodes() -> None:
    seeds = [300, 301, 302]
    jobs = [
        EvalJob("rh-paper", EnvConfig(n_aircraft=2, max_duration_s=8.0), tuple(seeds), True),
        EvalJob("obs", EnvConfig(n_aircraft=3, max_duration_s=8.0, shapes=("t",)), tuple(seeds)),
        EvalJob("random", EnvConfig(n_aircraft=2, max_duration_s=8.0), tuple(seeds)),
    ]
    finished: list[int] = []
    # Three whole jobs over two workers, then one job cut in two.
    parallel = evaluate_jobs(jobs, workers=2, on_job_done=lambda i, s: finished.append(i))
    (cut,) = evaluate_jobs(jobs[:1], workers=2)
    assert sorted(finished) == [0, 1, 2]
    for job, summary in zip(jobs, parallel, strict=True):
        serial = evaluate(make_vec_policy(job.policy), job.config, seeds, job.policy, job.record)
        assert_same_episodes(summary, serial)
        if job is jobs[0]:
            assert_same_episodes(cut, serial)
    # Only the first task of a job records (the CLI draws the first episode): it was compared.
    assert cut.episodes[0].trajectory is not None
    assert cut.episodes[-1].trajectory is None


@pytest.mark.slow
def test_eval_and_report_with_two_workers_print_the_serial_results(tmp_path: Path) -> None:
    args = ("--policy", "rh", "--episodes", "3", "--duration", "8", "--seed", "40", "--json")
    serial = wildfire("eval", *args)
    parallel = wildfire("eval", *args, "--workers", "2")
    assert serial.returncode == 0 and parallel.returncode == 0, serial.stderr + parallel.stderr
    expected = without_timings(json.loads(serial.stdout))
    assert without_timings(json.loads(parallel.stdout)) == expected

    def report(out: Path, *extra: str) -> dict[str, Any]:
        done = wildfire(
            "report",
            *("--policies", "random", "rh-paper", "--scenarios", "circular:2", "arc:3"),
            *("--episodes", "2", "--duration", "5", "--seed", "40", "--json"),
            *("--out", str(out), *extra),
        )
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    one, two = report(tmp_path / "serial"), report(tmp_path / "parallel", "--workers", "2")
    assert one["cells"] == two["cells"] and sorted(one["evaluated"]) == sorted(two["evaluated"])
    assert (tmp_path / "serial" / "results.md").read_text() == (
        tmp_path / "parallel" / "results.md"
    ).read_text()


@pytest.mark.slow
def test_ray_cluster_with_two_workers_gives_the_serial_results() -> None:
    ray = pytest.importorskip("ray")
    args = ("--policy", "rh-paper", "--episodes", "3", "--duration", "8", "--seed", "60")
    serial = wildfire("eval", *args, "--json")
    assert serial.returncode == 0, serial.stderr
    # A local cluster of 2 CPUs, started (and stopped) by this test alone.
    context = ray.init(num_cpus=2, include_dashboard=False, logging_level="ERROR")
    try:
        address = context.address_info["gcs_address"]
        on_ray = wildfire("eval", *args, "--json", "--ray", address)
    finally:
        ray.shutdown()
    assert on_ray.returncode == 0, on_ray.stderr
    assert without_timings(json.loads(on_ray.stdout)) == without_timings(json.loads(serial.stdout))


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["eval", "--ray", f"127.0.0.1:{free_port()}"], "no Ray cluster answers there"),
        (["eval", "--ray", "nowhere"], "--ray: expected HOST:PORT or auto"),
        (["eval", "--workers", "0"], "--workers"),
        (["eval", "--device", "tpu"], "--device 'tpu': expected cpu, cuda, cuda:N or auto"),
        (["report", "--ray", f"127.0.0.1:{free_port()}", "--episodes", "1"], "no Ray cluster"),
    ],
)
def test_bad_parallel_input_is_one_line_with_status_2(
    tmp_path: Path, args: list[str], needle: str
) -> None:
    if args[0] == "report":
        args = [*args, "--out", str(tmp_path / "r"), "--policies", "random"]
    result = wildfire(*args, "--duration", "1")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], result.stderr


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has CUDA")
@pytest.mark.parametrize(
    "args",
    [
        ["eval", "--policy", "obs", "--episodes", "1", "--duration", "1"],
        ["train", "--iterations", "1", "--run-dir", "RUN"],
        ["bench", "--only", "inference", "--quick"],
    ],
)
def test_cuda_where_there_is_none_is_one_line_with_status_2(
    tmp_path: Path, args: list[str]
) -> None:
    args = [str(tmp_path / "run") if a == "RUN" else a for a in args]
    result = wildfire(*args, "--device", "cuda")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--device cuda: CUDA is not available here" in lines[0], lines
    assert not (tmp_path / "run").exists()
