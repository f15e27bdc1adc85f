"""Evaluation spread over local processes or a Ray cluster, with exactly the serial results.

An evaluation job (a policy on a scenario over seeds) is cut into tasks of contiguous
seeds when there are fewer jobs than workers (one ``eval``; a ``report`` sends whole jobs);
each task is one :func:`~wildfire_learning.evaluate.evaluate` batch, run in a worker;
the tasks' episodes, concatenated in seed order, are the job's. They equal a serial run bit
for bit because a seed flies the same whatever else is in its batch: its fire, scenario and
aircraft randomness come from its own streams (``seeding.py``), the fire model is
batch-independent (``fire.py``), each planner draws from its aircraft's own generator and
sums rewards in a layout-independent order (``receding_horizon.py``), and a Q-network sees
one ownship at a time (``policies.QNetworkVecPolicy``). Only the timings differ:
``seconds_per_decision`` is the decision-weighted mean of the tasks', ``wall_time_s`` and
``planning_s`` their sums (the compute spent, not the elapsed time).

Executors:

* ``workers = 1``: in this process, one task after the other;
* ``workers = N``: a pool of N spawned processes (spawn, not fork: a forked child of a process
  that already runs torch threads can deadlock);
* ``ray_address``: Ray tasks of one CPU each on the cluster at that address (``auto``: the one
  ``ray start`` runs on this machine). Ray is imported only then. A task carries a policy file
  by its bytes, so the cluster's hosts need the project installed but not the file.

Tasks are started longest first (receding horizon, then Q-networks, then random; more aircraft
first), so the slow ones do not end up alone at the end of the run.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import socket
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from wildfire_agent.policy_names import (
    ORACLE_POLICY,
    PLANNER_POLICIES,
    has_network_file,
    resolve_policy_path,
)
from wildfire_learning.errors import LearningError
from wildfire_learning.evaluate import EvaluationSummary, evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig

RAY_CONNECT_TIMEOUT_S = 10.0
"""How long to wait for a Ray address to answer (TCP, then Ray's own handshake) before giving
up with one line and exit status 2."""


@dataclass(frozen=True)
class EvalJob:
    """One policy on one scenario: what a serial :func:`evaluate` call would fly."""

    policy: str
    """Policy name as given: ``rh``, ``rh-paper``, ``random``, ``obs``, ``belief`` or a path."""
    config: EnvConfig
    seeds: tuple[int, ...]
    record: bool = False
    """Record trajectories and final maps (of the first episode's task only)."""
    device: str = "cpu"
    """Where a Q-network runs (a resolved torch device name)."""


@dataclass(frozen=True)
class EvalTask:
    """A contiguous run of a job's seeds, self-contained for a worker on any host."""

    job: int
    """Index of the job it belongs to."""
    policy: str
    policy_file: bytes | None
    """Contents of the policy file (None for a built-in policy)."""
    config: EnvConfig
    seeds: tuple[int, ...]
    record: bool
    device: str


def split_seeds(seeds: Sequence[int], parts: int) -> list[tuple[int, ...]]:
    """``seeds`` cut into at most ``parts`` contiguous runs of near-equal length, in order."""
    parts = max(1, min(parts, len(seeds)))
    size, extra = divmod(len(seeds), parts)
    runs, start = [], 0
    for i in range(parts):
        end = start + size + (i < extra)
        runs.append(tuple(seeds[start:end]))
        start = end
    return runs


def make_tasks(jobs: Sequence[EvalJob], parts: int) -> list[EvalTask]:
    """Every job cut into ``parts`` tasks (policy files read once), longest first."""
    files: dict[str, bytes | None] = {}
    tasks = []
    for index, job in enumerate(jobs):
        if job.policy not in files:
            network = has_network_file(job.policy)  # a policy of your own is imported there
            files[job.policy] = resolve_policy_path(job.policy).read_bytes() if network else None
        for i, seeds in enumerate(split_seeds(job.seeds, parts)):
            tasks.append(
                EvalTask(
                    index,
                    job.policy,
                    files[job.policy],
                    job.config,
                    seeds,
                    job.record and i == 0,
                    job.device,
                )
            )
    return sorted(tasks, key=task_cost, reverse=True)  # a stable sort: ties keep job order


def task_cost(task: EvalTask) -> float:
    """Rough relative cost of a task, to start the longest first (measured ratios here)."""
    per_aircraft = 10.0 if task.policy in PLANNER_POLICIES else 0.1
    if task.policy == ORACLE_POLICY:
        per_aircraft = 100.0
    if task.policy_file is not None:
        per_aircraft = 1.0
    return per_aircraft * task.config.n_aircraft * len(task.seeds)


def run_task(task: EvalTask) -> EvaluationSummary:
    """Fly one task (in a worker): build its policy there, evaluate its seeds."""
    with tempfile.TemporaryDirectory(prefix="wildfire-eval-") as tmp:
        policy = task.policy
        if task.policy_file is not None:
            path = Path(tmp) / (Path(policy).stem + ".pt")
            path.write_bytes(task.policy_file)
            policy = str(path)
        vec_policy = make_vec_policy(policy, device=task.device)
        return evaluate(vec_policy, task.config, list(task.seeds), task.policy, task.record)


def merge(policy: str, parts: Sequence[EvaluationSummary]) -> EvaluationSummary:
    """One summary of a job's task summaries, given in seed order (see the module docstring)."""
    decisions = [sum(e.decisions for e in part.episodes) for part in parts]
    weighted = sum(p.seconds_per_decision * d for p, d in zip(parts, decisions, strict=True))
    return EvaluationSummary(
        policy=policy,
        episodes=[episode for part in parts for episode in part.episodes],
        seconds_per_decision=weighted / max(sum(decisions), 1),
        wall_time_s=sum(part.wall_time_s for part in parts),
        planning_s=sum(part.planning_s for part in parts),
    )


def evaluate_jobs(
    jobs: Sequence[EvalJob],
    workers: int = 1,
    ray_address: str | None = None,
    on_job_done: Callable[[int, EvaluationSummary], None] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[EvaluationSummary]:
    """Evaluate every job on ``workers`` local processes or on a Ray cluster.

    ``on_job_done(index, summary)`` is called as each job completes (in completion order);
    ``progress(done, total)`` after every task, with the episodes flown so far and in all.
    Returns the summaries in job order.
    """
    if ray_address is not None:
        ray = connect_ray(ray_address)
        slots = max(1, int(ray.cluster_resources().get("CPU", 1)))
    else:
        ray, slots = None, workers
    # Cut a job only when there are fewer jobs than slots: a batch of fewer episodes costs
    # more per episode (the planners' numpy calls are per batch, measured ~1.5x for half a
    # batch), and with many jobs, longest first, whole jobs already keep every slot busy.
    tasks = make_tasks(jobs, -(-slots // max(len(jobs), 1)))
    pending = {i: sum(t.job == i for t in tasks) for i in range(len(jobs))}
    results: dict[int, list[EvaluationSummary]] = {i: [] for i in range(len(jobs))}
    summaries: list[EvaluationSummary | None] = [None] * len(jobs)
    done, total = 0, sum(len(job.seeds) for job in jobs)

    def finished(task: EvalTask, summary: EvaluationSummary) -> None:
        nonlocal done
        results[task.job].append(summary)
        pending[task.job] -= 1
        done += len(task.seeds)
        if pending[task.job] == 0:
            parts_in_order = sorted(results[task.job], key=lambda s: s.episodes[0].seed)
            merged = merge(jobs[task.job].policy, parts_in_order)
            summaries[task.job] = merged
            if on_job_done is not None:
                on_job_done(task.job, merged)
        if progress is not None:
            progress(done, total)

    if ray is not None:
        _run_on_ray(ray, tasks, finished)
    elif workers <= 1:
        for task in tasks:
            finished(task, run_task(task))
    else:
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
            futures = {pool.submit(run_task, task): task for task in tasks}
            for future in as_completed(futures):
                finished(futures[future], future.result())
    return [s for s in summaries if s is not None]


# ------------------------------------------------------------------------------------ Ray
def _probe(address: str) -> None:
    """Fail fast, in one line, when nothing listens at ``HOST:PORT`` (``ray.init`` would
    retry for a minute or more)."""
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not port.isdigit() or not host:
        raise LearningError(f"--ray {address!r}: expected HOST:PORT (e.g. 10.0.0.5:6379) or auto")
    try:
        with socket.create_connection((host, int(port)), timeout=RAY_CONNECT_TIMEOUT_S):
            pass
    except OSError as error:
        reason = "timed out" if isinstance(error, TimeoutError) else error.strerror or str(error)
        raise LearningError(
            f"--ray {address}: no Ray cluster answers there ({reason}); start one with "
            "`ray start --head` or give its address"
        ) from None


@contextlib.contextmanager
def _stderr_silenced() -> Iterator[None]:
    """File descriptor 2 sent to /dev/null for the block (C++ libraries write there)."""
    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def connect_ray(address: str) -> Any:
    """The ``ray`` module, connected to the cluster at ``address`` (or ``auto``)."""
    # Ray's default for a driver that cannot connect is ~20 retries a second apart: bound the
    # wait (still ample for a live cluster; a user's own setting wins).
    os.environ.setdefault("RAY_gcs_server_port_wait_time_s", str(int(RAY_CONNECT_TIMEOUT_S)))
    try:
        import ray
    except ModuleNotFoundError:
        raise LearningError(
            f"--ray {address}: Ray is not installed (pip install -r requirements.txt)"
        ) from None
    if address != "auto":
        _probe(address)
    if not ray.is_initialized():
        try:
            # Each failed retry logs a warning from C++ straight to file descriptor 2, before
            # Ray's log level applies: the user gets our one line instead.
            with _stderr_silenced():
                ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as error:
            first = str(error).strip().splitlines()[0] if str(error).strip() else "no answer"
            raise LearningError(f"--ray {address}: cannot connect ({first})") from None
    return ray


def _run_on_ray(
    ray: Any, tasks: list[EvalTask], finished: Callable[[EvalTask, EvaluationSummary], None]
) -> None:
    remote = ray.remote(num_cpus=1, max_retries=0)(run_task)
    refs = {remote.remote(task): task for task in tasks}
    waiting = list(refs)
    while waiting:
        ready, waiting = ray.wait(waiting, num_returns=1)
        finished(refs[ready[0]], ray.get(ready[0]))


__all__ = [
    "RAY_CONNECT_TIMEOUT_S",
    "EvalJob",
    "EvalTask",
    "connect_ray",
    "evaluate_jobs",
    "make_tasks",
    "merge",
    "run_task",
    "split_seeds",
    "task_cost",
]
