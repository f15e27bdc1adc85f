"""Test-wide settings.

Every test that touches DDS must stay on this machine: Cyclone DDS is pinned to the
loopback-only configuration in ``config/``, Fast DDS (real rclpy) to ``config/fastdds_loopback.xml``
with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, and each pytest session picks its own
``ROS_DOMAIN_ID`` so parallel runs (two developers, CI, the two workers of ``scripts/test.sh``)
never see each other's traffic.
Child processes started by tests inherit these variables.

The backend is explicit: ``WILDFIRE_ROS_BACKEND`` is ``rclpy`` where the real rclpy imports,
else ``dds``; ``scripts/test.sh`` runs the ROS-facing tests a second time with ``dds``.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import tempfile
from pathlib import Path
from typing import TextIO

REPO_ROOT = Path(__file__).resolve().parents[1]
LOOPBACK_CONFIG = REPO_ROOT / "config" / "cyclonedds_loopback.xml"
FASTDDS_LOOPBACK_PROFILE = REPO_ROOT / "config" / "fastdds_loopback.xml"

os.environ["CYCLONEDDS_URI"] = LOOPBACK_CONFIG.as_uri()
os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(FASTDDS_LOOPBACK_PROFILE)
os.environ.pop("FASTDDS_DEFAULT_PROFILES_FILE", None)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
# Domain ids 0..101 are safe on Linux for any participant count; 0 is the usual default, so
# a test process (a session, or each pytest-xdist worker of one) claims one of 1..100 that no
# other test process on this machine holds: an exclusive lock on a file per id, held until it
# exits. Ids derived from process ids alone collided: two sessions at once (a developer's and
# CI's) then recorded each other's messages.
_DOMAIN_LOCKS = Path(tempfile.gettempdir()) / "wildfire-test-domains"


def _claim_domain_id() -> tuple[int, TextIO]:
    _DOMAIN_LOCKS.mkdir(exist_ok=True)
    for offset in range(100):
        domain = 1 + (os.getpid() + offset) % 100
        lock = open(_DOMAIN_LOCKS / f"{domain}.lock", "w")  # noqa: SIM115 (held until exit)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        return domain, lock
    raise RuntimeError(f"every ROS domain id 1..100 is held by a test process ({_DOMAIN_LOCKS})")


_DOMAIN_ID, _DOMAIN_LOCK = _claim_domain_id()
os.environ["ROS_DOMAIN_ID"] = str(_DOMAIN_ID)


def _default_backend() -> str:
    try:
        import rclpy  # noqa: F401
    except ImportError:
        return "dds"
    return "rclpy"


if os.environ.get("WILDFIRE_ROS_BACKEND", "auto").strip().lower() in ("", "auto"):
    os.environ["WILDFIRE_ROS_BACKEND"] = _default_backend()
# One intra-op thread per process (as the `wildfire` command sets): tests start many
# processes on two cores, where OpenMP's spinning threads would slow everything down.
os.environ.setdefault("OMP_NUM_THREADS", "1")
# Matplotlib must never try to open a window in tests or CI.
os.environ.setdefault("MPLBACKEND", "Agg")


# --- ROS runtime fixtures (wildfire_msgs_py) ----------------------------------------------------

import pytest  # noqa: E402


@pytest.fixture
def ros_runtime():
    """The active runtime backend, initialized for one test and always shut down after it."""
    from wildfire_ros import runtime

    runtime.rclpy.init(args=[])
    try:
        yield runtime
    finally:
        runtime.rclpy.try_shutdown()


@pytest.fixture
def dds_env() -> dict[str, str]:
    """Environment for child processes: loopback config, this session's domain, no user site."""
    env = dict(os.environ)
    env["PYTHONUNBUFFERED"] = "1"
    return env


# --- parallel workers (pytest-xdist) ---------------------------------------------------------

SYSTEM_MODULES = {"test_multihost.py", "test_network_faults.py", "test_network_isolation.py"}
"""Modules whose tests build network namespaces or start systems without the ``dds`` marker."""
QUICK_MODULES = {
    "test_msgs_codecs.py",  # wildfire_msgs_py
    "test_map_geometry.py",
    "test_dds_params.py",  # wildfire_ros
    "test_fire.py",  # wildfire_sim
    "test_episode.py",
    "test_radio.py",  # wildfire_belief
    "test_dynamics.py",  # wildfire_agent
    "test_policy_names.py",
    "test_env.py",  # wildfire_learning
    "test_run_params.py",  # wildfire_bringup, wildfire_cli (one lockstep system)
    "test_core_cli.py",  # wildfire_cli
    "test_bench_cli.py",  # wildfire_bench, wildfire_testbed
}
"""Modules of marker ``quick`` (``scripts/test.sh --quick``): a few minutes that touch every
package, for the edit loop. The full suite is what CI runs."""


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Put every test that starts a multi-process system (marker ``dds``, or a module of
    ``SYSTEM_MODULES``) in one xdist group: under ``scripts/test.sh``'s two workers, systems
    run one at a time on one worker while the other worker takes the in-process tests.

    Two systems at once on two cores pushed tests past their margins (measured: a recorder
    exiting with a traceback from rclpy's task finaliser, a lockstep run on four virtual hosts
    diverging from eval), so parallelism is kept where it is harmless.

    ``tryfirst``: an xdist worker reads the groups in its own ``pytest_collection_modifyitems``,
    registered after this conftest and so called before it unless this one goes first. (And
    pytest 9.2 drops the group xdist 3.8 writes into the node id, requirements.txt.) Both
    together let two systems run at once: two floods side by side in CI, a 15 s lockstep
    flight past its 270 s limit (32 s alone)."""
    for item in items:
        if item.path.name in QUICK_MODULES:
            item.add_marker(pytest.mark.quick)
        if item.get_closest_marker("xdist_group") is not None:
            continue  # a test that chose its group itself
        if item.get_closest_marker("dds") is not None or item.path.name in SYSTEM_MODULES:
            item.add_marker(pytest.mark.xdist_group("system"))


@pytest.fixture(autouse=True)
def _system_tests_first(request: pytest.FixtureRequest) -> None:
    """Under pytest-xdist, give the CPU to system tests first: their worker runs at nice -5,
    an in-process test's at +10 (children inherit it). Beside a busy in-process test, a
    multi-process system then runs as if alone, as its timing margins assume. Without root a
    lower niceness cannot be set, and the priorities stay as they are."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        return
    group = request.node.get_closest_marker("xdist_group")
    system = group is not None and group.args[:1] == ("system",)
    with contextlib.suppress(PermissionError):
        os.setpriority(os.PRIO_PROCESS, 0, -5 if system else 10)
