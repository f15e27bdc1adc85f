"""A field map in the distributed system, recorded (500 x 500, two fires, eight aircraft
composed four to a process): the run equals ``wildfire eval``; a plain rclpy peer hearing it
live and the bag read back rebuild the belief of every tick (keyframes and deltas), and the
bag the fuel (whole map and tiles), exactly. Limited radio links and cameras fly a field map
as eval does."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from wildfire_belief.aggregator import BeliefAggregator
from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_msgs_py import contract
from wildfire_msgs_py.belief_codec import belief_grid
from wildfire_msgs_py.belief_delta import BeliefMirror
from wildfire_msgs_py.codecs import time_from_msg, visit_from_msg
from wildfire_msgs_py.grid_tiles import TiledMap
from wildfire_msgs_py.wire_checks import (
    checked_age_image,
    checked_belief_delta,
    checked_belief_values,
    checked_fuel_grid,
    checked_fuel_tile,
)
from wildfire_ros.bag import read_messages
from wildfire_sim.episode import FireEpisode, decisions_in
from wildfire_sim.grid import MapGeometry
from wildfire_sim.ignition import ignite
from wildfire_sim.landscape import Landscape
from wildfire_world.env import EnvConfig

pytestmark = [pytest.mark.dds, pytest.mark.slow, pytest.mark.timeout(300)]
WILDFIRE = str(Path(sys.executable).parent / "wildfire")
FIELD = MapGeometry(500, 500)
SEED, DURATION, AIRCRAFT = 31, 10.0, 8


def wildfire_json(args: list[str], env: dict[str, str]) -> dict[str, Any]:
    """The JSON summary of a ``wildfire`` command that must succeed."""
    done = subprocess.run(
        [WILDFIRE, *args], env=env, capture_output=True, text=True, timeout=280, check=False
    )
    assert done.returncode == 0, done.stderr
    summary: dict[str, Any] = json.loads(done.stdout)
    return summary


# A ROS 2 user's own reader: plain rclpy and its message packages, and the project's numpy
# mirror (``wildfire_msgs_py.belief_delta``) to rebuild the belief of each tick it hears.
_RCLPY_PEER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    import rclpy
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from nav_msgs.msg import OccupancyGrid
    from sensor_msgs.msg import Image
    from std_msgs.msg import Int32MultiArray
    from wildfire_msgs_py.belief_delta import BeliefMirror, delta_from_msg
    from wildfire_msgs_py.system_codecs import age_image_from_msg

    out, last_stamp = sys.argv[1], int(sys.argv[2])
    rclpy.init()
    node = rclpy.create_node("field_peer")
    qos = QoSProfile(
        depth=100,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    mirror, frames = BeliefMirror(), {}

    def stamp(msg):
        return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec

    def keep(done):
        frames.update({f.stamp: f for f in done})

    def grid(msg):
        values = np.array(msg.data, dtype=np.int8).reshape(msg.info.height, msg.info.width)
        keep(mirror.on_key_grid(stamp(msg), values))

    node.create_subscription(OccupancyGrid, "/wildfire/belief", grid, qos)
    node.create_subscription(
        Image, "/wildfire/belief_age_exact",
        lambda m: keep(mirror.on_key_ages(stamp(m), age_image_from_msg(m))), qos)
    node.create_subscription(
        Int32MultiArray, "/wildfire/belief_delta",
        lambda m: keep(mirror.on_delta(delta_from_msg(m))), qos)
    print("listening", flush=True)
    end = time.monotonic() + 240
    while time.monotonic() < end and last_stamp not in frames:
        rclpy.spin_once(node, timeout_sec=0.1)
    np.savez(out, stamps=np.array(sorted(frames)),
             grids=np.stack([frames[s].grid for s in sorted(frames)]),
             ages=np.stack([frames[s].age_s for s in sorted(frames)]))
    """
)


def test_a_recorded_field_run_rebuilds_its_belief_and_fuel(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    bag = tmp_path / "bag"
    heard = tmp_path / "peer.npz"
    last_stamp = decisions_in(DURATION) * contract.DECISION_PERIOD_NS
    peer = None
    if importlib.util.find_spec("rclpy") is not None:  # else: the Cyclone layer only, no peer
        peer = subprocess.Popen(
            [sys.executable, "-c", _RCLPY_PEER, str(heard), str(last_stamp)],
            env={**dds_env, "WILDFIRE_ROS_BACKEND": "rclpy"},
            stdout=subprocess.PIPE,
            text=True,
        )
        assert peer.stdout is not None and peer.stdout.readline().strip() == "listening"
    summary = wildfire_json(
        [
            *("run", "--policy", "rh", "--aircraft", str(AIRCRAFT), "--seed", str(SEED)),
            *("--map-size", "500,500", "--ignitions", "2", "--duration", str(DURATION)),
            *("--fast", "--json", "--record", str(bag), "--agents-per-process", "4"),
        ],
        dds_env,
    )
    assert peer is None or peer.wait(timeout=60) == 0
    assert summary["map_size"] == [500, 500] and summary["ignitions"] == 2
    assert len(summary["composed_agents"]) == 2  # eight agents in two processes
    ground = Landscape(FIELD, ignitions=2)
    config = EnvConfig(
        n_aircraft=AIRCRAFT, max_duration_s=DURATION, geometry=FIELD, landscape=ground
    )
    reference = evaluate(make_vec_policy("rh"), config, [SEED]).episodes[0]
    assert (summary["score"], summary["decisions"]) == (reference.score, reference.decisions)

    mirror, fuel = BeliefMirror(), TiledMap()
    frames, visits, counts = {}, {}, {"whole": 0, "tiles": 0}
    for record in read_messages(bag):
        msg, topic = record.message, record.topic
        if topic == contract.BELIEF.name:
            done_frames = mirror.on_key_grid(*checked_belief_values(msg, FIELD))
        elif topic == contract.BELIEF_AGE_EXACT.name:
            done_frames = mirror.on_key_ages(*checked_age_image(msg, FIELD))
        elif topic == contract.BELIEF_DELTA.name:
            done_frames = mirror.on_delta(checked_belief_delta(msg, FIELD))
        else:
            done_frames = []
            if topic == contract.FUEL_MAP.name:
                fuel.on_whole(*checked_fuel_grid(msg, FIELD))
                counts["whole"] += 1
            elif topic == contract.FUEL_TILES.name:
                fuel.on_tile(checked_fuel_tile(msg, FIELD))
                counts["tiles"] += 1
            elif topic.endswith("/visit"):
                tick = time_from_msg(msg.header.stamp) // contract.DECISION_PERIOD_NS
                visits.setdefault(tick, {})[topic] = visit_from_msg(msg)
        frames |= {frame.stamp: frame for frame in done_frames}

    # The belief of every tick, exactly: the visits of the bag merged from the ignition.
    aggregator = BeliefAggregator(ignite(SEED, "circular", ground).burning)
    ticks, truth = summary["decisions"], {}
    assert sorted(frames) == [t * contract.DECISION_PERIOD_NS for t in range(ticks + 1)]
    for tick in range(ticks + 1):
        if tick:
            aggregator.merge([visits[tick][k] for k in sorted(visits[tick])])
        frame = frames[tick * contract.DECISION_PERIOD_NS]
        np.testing.assert_array_equal(frame.grid, belief_grid(aggregator.burning))
        assert np.array_equal(frame.age_s, aggregator.age_s()), f"tick {tick}"
        truth[frame.stamp] = frame
    if peer is not None:  # the rclpy peer heard the run live and rebuilt the same belief
        with np.load(heard) as peer_frames:
            stamps = [int(s) for s in peer_frames["stamps"]]
            grids, ages = peer_frames["grids"], peer_frames["ages"]
        assert len(stamps) >= ticks // 2 and last_stamp in stamps
        for stamp, grid, age_s in zip(stamps, grids, ages, strict=True):
            np.testing.assert_array_equal(grid, truth[stamp].grid)
            assert np.array_equal(age_s, truth[stamp].age_s), f"peer, {stamp} ns"

    # The fuel: whole once (10 s is 4 fire steps), tiles after; the fire's own at the end.
    wind = (float(summary["wind"][0]), float(summary["wind"][1]))
    episode = FireEpisode(
        SEED, "circular", wind, max_decisions=decisions_in(DURATION), ground=ground
    )
    while not episode.final:
        episode.advance()
    assert counts["whole"] == 1 and counts["tiles"] > 0
    np.testing.assert_array_equal(fuel.grid, episode.fuel)


@pytest.mark.parametrize(
    ("policy", "extra"),
    [
        # Replicas, radio and catch-up, on a fire pre-burnt to 10 ha.
        ("rh", ["--aircraft", "4", "--comm", "range=400,loss=0.2", "--preburn-area", "100000"]),
        ("rh-belief", ["--aircraft", "2", "--sensor", "camera"]),  # the filtered belief
    ],
)
def test_limited_links_and_cameras_fly_a_field_map_as_eval(
    policy: str, extra: list[str], dds_env: dict[str, str]
) -> None:
    common = [
        *("--policy", policy, "--seed", "17", "--map-size", "300,300", "--ignitions", "2"),
        *("--duration", "10", "--json", *extra),
    ]
    summary = wildfire_json(["run", "--fast", *common], dds_env)
    reference = wildfire_json(["eval", "--episodes", "1", *common], dds_env)
    assert summary["score"] == reference["scores"][0] and summary["decisions"] == 100
    assert sum(v["dropped"] for v in summary["dropped_inputs"].values()) == 0
    if "--comm" in extra:
        assert summary["radio_bytes_per_s_per_aircraft"] <= 1024


def test_fuel_and_ignition_rasters_fly_in_the_system_as_in_eval(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    """A land-cover raster (CORINE classes, firebreaks, water) and an ignition raster: the
    command reads them once, every node reads the resolved ground file, and the run equals
    eval, under limited links too (the replicas start from the raster's ignition)."""
    from wildfire_sim.demo_raster import landcover_codes

    np.save(tmp_path / "cover.npy", landcover_codes(240, 260, seed=3))
    ignition = np.zeros((240, 260), dtype=np.uint8)
    ignition[100:106, 90:96] = ignition[150:154, 170:174] = 1
    np.save(tmp_path / "ignition.npy", ignition)
    common = [
        *("--policy", "rh", "--seed", "23", "--aircraft", "3", "--comm", "range=500,loss=0.2"),
        *("--fuel-map", str(tmp_path / "cover.npy"), "--fuel-classes", "corine"),
        *("--ignition-map", str(tmp_path / "ignition.npy"), "--duration", "10", "--json"),
    ]
    logs = tmp_path / "logs"
    summary = wildfire_json(["run", "--fast", "--log-dir", str(logs), *common], dds_env)
    reference = wildfire_json(["eval", "--episodes", "1", *common], dds_env)
    assert summary["score"] == reference["scores"][0] and summary["decisions"] == 100
    assert summary["fuel_map"] == reference["fuel_map"]
    assert summary["ignition_cells"] == reference["ignition_cells"] > 0
    assert sum(v["dropped"] for v in summary["dropped_inputs"].values()) == 0
    assert (logs / "ground.npz").is_file()
