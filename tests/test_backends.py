"""Real rclpy and our Cyclone DDS layer in one system, seen by independent peers.

* a mixed lockstep system (the simulator and aggregator on one backend, the agents on the
  other) flies exactly what ``wildfire eval`` flies;
* a plain rclpy process (no project import) lists the nodes of a running system in the ROS
  graph and hears ``/uav0/odom`` at 10 Hz (by its stamps);
* a plain Cyclone DDS reader (the ``cyclonedds`` package, not our node layer) hears the
  contract topics of the same system.
"""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_ros.runtime import BACKEND
from wildfire_world.env import EnvConfig

pytestmark = [pytest.mark.dds, pytest.mark.timeout(300)]
WILDFIRE = str(Path(sys.executable).parent / "wildfire")


def _rclpy_importable() -> bool:
    try:
        import rclpy  # noqa: F401
    except ImportError:
        return False
    return True


needs_rclpy = pytest.mark.skipif(
    not _rclpy_importable(), reason="rclpy does not import (no ROS 2 Jazzy wheels here)"
)


@needs_rclpy
def test_mixed_backends_lockstep_equals_evaluate(dds_env: dict[str, str]) -> None:
    other = "dds" if BACKEND == "rclpy" else "rclpy"
    seed, duration = 3, 15.0
    done = subprocess.run(
        [
            *(WILDFIRE, "run", "--aircraft", "2", "--policy", "rh", "--seed", str(seed)),
            *("--duration", str(duration), "--wind", "0.2,0.1", "--fast", "--json"),
            *("--agent-backend", other),
        ],
        env=dds_env,
        capture_output=True,
        text=True,
        timeout=200,
    )
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["backend"] == BACKEND
    config = EnvConfig(n_aircraft=2, shapes=("circular",), wind=(0.2, 0.1), max_duration_s=duration)
    reference = evaluate(make_vec_policy("rh"), config, [seed]).episodes[0]
    assert summary["score"] == reference.score
    assert summary["decisions"] == reference.decisions


# What an independent ROS 2 user would run: plain rclpy and std message packages only.
_RCLPY_PEER = textwrap.dedent(
    """
    import json, time
    import rclpy
    from nav_msgs.msg import Odometry

    rclpy.init()
    node = rclpy.create_node("independent_peer")
    stamps = []
    node.create_subscription(
        Odometry, "/uav0/odom",
        lambda m: stamps.append(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec), 50)
    names = set()
    end = time.monotonic() + 150  # a loaded machine takes long to start the system
    while time.monotonic() < end and len(stamps) < 30:
        rclpy.spin_once(node, timeout_sec=0.1)
        names |= {ns.rstrip("/") + "/" + n for n, ns in node.get_node_names_and_namespaces()}
    print(json.dumps({"nodes": sorted(names), "stamps": stamps}))
    node.destroy_node()
    rclpy.shutdown()
    """
)

# A plain Cyclone DDS reader of the ROS 2 wire format (rt/<topic>, <pkg>::msg::dds_::<T>_);
# only the IDL type class comes from the project.
_CYCLONE_PEER = textwrap.dedent(
    """
    import json, os, time
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from wildfire_msgs_py.types import get_message

    participant = DomainParticipant(int(os.environ["ROS_DOMAIN_ID"]))
    readers = {
        name: DataReader(participant, Topic(participant, "rt" + name, get_message(kind)))
        for name, kind in [
            ("/uav0/odom", "nav_msgs/msg/Odometry"),
            ("/wildfire/fire_map", "nav_msgs/msg/OccupancyGrid"),
            ("/wildfire/belief", "nav_msgs/msg/OccupancyGrid"),
        ]
    }
    counts = {name: 0 for name in readers}
    end = time.monotonic() + 150
    while time.monotonic() < end and min(counts.values()) < 3:
        for name, reader in readers.items():
            counts[name] += len(reader.take(N=100))
        time.sleep(0.05)
    print(json.dumps(counts))
    """
)


@needs_rclpy
def test_independent_peers_see_a_running_system(dds_env: dict[str, str]) -> None:
    if BACKEND != "rclpy":
        pytest.skip("our Cyclone DDS layer publishes no ROS graph (node names) for rclpy to list")
    run = subprocess.Popen(
        [WILDFIRE, "run", "--aircraft", "2", "--policy", "rh", "--realtime", "--duration", "60"],
        env=dds_env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        peer_env = {**dds_env, "WILDFIRE_ROS_BACKEND": "dds"}
        rclpy_peer = subprocess.Popen(
            [sys.executable, "-c", _RCLPY_PEER],
            env=dds_env,
            stdout=subprocess.PIPE,
            text=True,
        )
        cyclone_peer = subprocess.Popen(
            [sys.executable, "-c", _CYCLONE_PEER],
            env=peer_env,
            stdout=subprocess.PIPE,
            text=True,
        )
        seen = json.loads(rclpy_peer.communicate(timeout=200)[0])
        counts = json.loads(cyclone_peer.communicate(timeout=200)[0])
    finally:
        run.terminate()
        run.wait(timeout=60)
    assert {"/fire_simulator", "/belief_aggregator", "/uav0/agent", "/uav1/agent"} <= set(
        seen["nodes"]
    )
    stamps = sorted(seen["stamps"])
    assert len(stamps) >= 30
    steps = [b - a for a, b in itertools.pairwise(stamps)]
    # 10 Hz: consecutive odometry stamps 0.1 s apart (the agent's 100 ms decision slots).
    assert sorted(steps)[len(steps) // 2] == pytest.approx(0.1, abs=0.02)
    assert min(counts.values()) >= 3, counts


@pytest.mark.dds
@pytest.mark.parametrize("choice", ["", "single", "bogus"])
def test_executor_choice(choice: str, dds_env: dict[str, str]) -> None:
    """rclpy nodes spin on the events executor unless WILDFIRE_ROS_EXECUTOR says otherwise."""
    probe = (
        "from wildfire_ros import runtime; runtime.rclpy.init(args=[]); "
        "print(type(runtime.make_executor()).__name__)"
    )
    env = dict(dds_env, WILDFIRE_ROS_EXECUTOR=choice)
    result = subprocess.run(
        [sys.executable, "-c", probe], env=env, capture_output=True, text=True, timeout=60
    )
    if choice == "bogus":
        assert result.returncode != 0
        assert "WILDFIRE_ROS_EXECUTOR='bogus': expected one of events, single" in result.stderr
        return
    assert result.returncode == 0, result.stderr
    events = BACKEND == "rclpy" and choice != "single"
    assert result.stdout.strip() == ("EventsExecutor" if events else "SingleThreadedExecutor")
