"""Camera sensing in the distributed system: a lockstep run equals ``wildfire eval
--sensor camera`` bit for bit (score, false alarms, flipped reports, belief, every flight
path), each camera's reports are on the wire and in the bag, and the shared belief carries
the probability of burning."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from wildfire_belief.radio import CommModel
from wildfire_learning.bag_transitions import transitions_from_bags
from wildfire_learning.parallel import EvalJob, evaluate_jobs
from wildfire_learning.replay import ImageCodec
from wildfire_world.env import EnvConfig, WildfireVecEnv


def time_ns(msg: object) -> int:
    stamp = msg.header.stamp  # type: ignore[attr-defined]
    return int(stamp.sec) * 10**9 + int(stamp.nanosec)


pytestmark = [pytest.mark.dds, pytest.mark.timeout(180)]
WILDFIRE = str(Path(sys.executable).parent / "wildfire")


def camera_world(
    n: int, duration: float, wind_filter: bool = False, comm: str = "ideal"
) -> EnvConfig:
    """The environment a camera run of ``n`` aircraft equals (circular fire, p = 0.1)."""
    return EnvConfig(
        n_aircraft=n, shapes=("circular",), max_duration_s=duration, sensor="camera",
        pixel_error=0.1, wind_filter=wind_filter, comm=CommModel.parse(comm),
    )  # fmt: skip


def fresh_evaluation(policy: str, config: EnvConfig, seed: int, record: bool = False) -> Any:
    """``evaluate``'s episode of ``seed``, flown in a fresh (spawned) process, as ``wildfire
    eval --workers 2`` flies it. In this test process, after the other tests here, an
    evaluation of the obs-camera run below scored 262 in 2 of 7 runs, where the system, the
    aggregator and every fresh process scored 276; what in the process state changes it is
    not found yet (docs/testing.md)."""
    job = EvalJob(policy, config, (seed,), record=record)
    return evaluate_jobs([job], workers=2)[0].episodes[0]


def fly_with_cameras(
    tmp_path: Path,
    env: dict[str, str],
    policy: str,
    seed: int,
    n: int,
    duration: float,
    *extra: str,
) -> dict:
    """A lockstep camera run recorded to ``tmp_path / "bag"``: its ``--json`` summary."""
    result = subprocess.run(
        [WILDFIRE, "run", "--policy", policy, "--aircraft", str(n), "--sensor", "camera",
         *extra, "--seed", str(seed), "--duration", str(duration), "--fast", "--json",
         "--record", str(tmp_path / "bag"), "--log-dir", str(tmp_path / "logs")],
        env=env, capture_output=True, text=True, timeout=150,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def test_lockstep_with_cameras_equals_evaluate(tmp_path: Path, dds_env: dict[str, str]) -> None:
    from wildfire_msgs_py.camera_codec import footprint_outline, outlines_from_msg
    from wildfire_msgs_py.codecs import grid_from_msg, visit_from_msg
    from wildfire_msgs_py.system_codecs import stamped_state_from_msg
    from wildfire_ros.bag import SENSOR_KEY, read_custom_data, read_messages

    # The camera-trained network reads the fused belief's probability of burning from
    # /wildfire/belief (in whole percent): its decisions depend on every report.
    policy, seed, n, duration = "belief-camera", 2000003, 2, 15.0
    bag = tmp_path / "bag"
    summary = fly_with_cameras(tmp_path, dds_env, policy, seed, n, duration)
    config = camera_world(n, duration)
    expected = fresh_evaluation(policy, config, seed, record=True)
    assert (summary["sensor"], summary["pixel_error"]) == ("camera", 0.1)
    assert summary["score"] == expected.score > 0
    assert summary["aggregator_score"] == expected.score
    assert summary["decisions"] == expected.decisions
    assert summary["false_alarms"] == expected.false_alarms
    assert summary["flipped_fraction"] == expected.flipped_fraction
    assert summary["belief_iou"] == expected.belief_iou
    assert summary["score_ceiling"] == expected.score_ceiling
    assert all(drops["dropped"] == 0 for drops in summary["dropped_inputs"].values())

    states: dict[str, dict[int, np.ndarray]] = {}
    reports: dict[str, int] = {}
    probabilities = set()
    seen_cells = 0
    cameras = [f"/uav{k}/camera{c}/cells" for k in range(n) for c in range(4)]
    footprints = [f"/uav{k}/camera/footprints" for k in range(n)]
    topics = [f"/uav{k}/state_stamped" for k in range(n)] + cameras + ["/wildfire/belief"]
    windows: dict[tuple[str, int], object] = {}
    outlines: dict[tuple[str, int], list[np.ndarray]] = {}
    for message in read_messages(bag, topics=topics + footprints):
        if message.topic in footprints:
            stamped = time_ns(message.message.markers[0])
            outlines[message.topic, stamped] = outlines_from_msg(message.message)
        elif message.topic in cameras:
            window = visit_from_msg(message.message)
            windows[message.topic, time_ns(message.message)] = window
            assert window.visited.shape == (61, 61)  # off the map a camera may see nothing
            reports[message.topic] = reports.get(message.topic, 0) + 1
            seen_cells += int(window.visited.sum())
        elif message.topic == "/wildfire/belief":
            probabilities |= set(np.unique(grid_from_msg(message.message)).tolist())
        else:
            stamp, vector = stamped_state_from_msg(message.message)
            states.setdefault(message.topic, {})[stamp] = vector
    for k in range(n):
        recorded = states[f"/uav{k}/state_stamped"]
        path = np.array([recorded[t][:2] for t in sorted(recorded)])
        assert np.array_equal(path, expected.trajectory[:, k])
    # One report per camera and decision, from tick 1.
    assert reports == dict.fromkeys(cameras, expected.decisions)
    assert seen_cells > 100 * expected.decisions
    # The footprint outlines (for RViz) trace the very cells each camera reported. They are a
    # volatile stream: the recorder, which discovers topics as they appear, may miss the first,
    # and the run may stop it before the last arrives.
    assert len(outlines) >= n * expected.decisions // 2
    for (topic, stamp), drawn in outlines.items():
        k = topic.split("/")[1]
        for c, outline in enumerate(drawn):
            window = windows[f"/{k}/camera{c}/cells", stamp]
            np.testing.assert_array_equal(outline, footprint_outline(window))  # type: ignore[arg-type]
    # The belief is a probability in percent, not just 0 and 100.
    assert probabilities - {0, 100} and min(probabilities) >= 0 and max(probabilities) <= 100
    # The bag says what it was recorded with, and rebuilds the environment's transitions:
    # the reports drawn again, the filtered belief fused again.
    assert read_custom_data(bag)[SENSOR_KEY] == "camera,0.1"
    assert_rebuilds_as_the_environment(bag, config, seed)
    # The observation approach's camera images and rewards, from the reports drawn again.
    assert_rebuilds_as_the_environment(bag, config, seed, "obs")


def assert_rebuilds_as_the_environment(
    bag: Path, config: EnvConfig, seed: int, approach: str = "belief"
) -> None:
    """The bag's transitions equal the environment's, images and rewards."""
    config = replace(config, observation=approach, reward=approach)
    sequences = transitions_from_bags([bag], approach, config)
    actions = np.stack([s.actions for s in sequences], axis=1)
    env = WildfireVecEnv(config, 1)
    codec = ImageCodec.for_approach(approach, config.sensor)
    images = [codec.encode(env.reset([seed])["image"][0])]
    rewards = []
    for action in actions:
        result = env.step(action[None])
        images.append(codec.encode(result.observations["image"][0]))
        rewards.append(result.rewards[0])
    for k, sequence in enumerate(sequences):
        np.testing.assert_array_equal(sequence.images, np.stack(images)[:, k])
        np.testing.assert_array_equal(sequence.rewards, np.array(rewards)[:, k])


def test_lockstep_with_the_wind_filter_equals_evaluate(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    from wildfire_ros.bag import WIND_FILTER_KEY, read_custom_data

    # The aggregator and the run monitor step a particle filter of fire models over the wind
    # and hand its estimate to the belief's process term, as the environment does; the
    # network reads the resulting probability of burning.
    policy, seed, n, duration = "belief-camera", 2000004, 2, 12.5
    bag = tmp_path / "bag"
    summary = fly_with_cameras(tmp_path, dds_env, policy, seed, n, duration, "--wind-filter")
    config = camera_world(n, duration, wind_filter=True)
    expected = fresh_evaluation(policy, config, seed)
    without = fresh_evaluation(policy, replace(config, wind_filter=False), seed)
    assert summary["wind_filter"] is True
    assert summary["score"] == summary["aggregator_score"] == expected.score > 0
    assert summary["false_alarms"] == expected.false_alarms
    assert summary["belief_iou"] == expected.belief_iou
    # The filter changed the belief: the same flight without it fuses otherwise.
    assert without.belief_iou != expected.belief_iou
    assert read_custom_data(bag)[WIND_FILTER_KEY] == "true"
    assert_rebuilds_as_the_environment(bag, config, seed)


def assert_flight_paths(bag: Path, n: int, trajectory: np.ndarray) -> None:
    """Every aircraft's recorded path equals the environment's ``trajectory`` (T, n, 2)."""
    from wildfire_msgs_py.system_codecs import stamped_state_from_msg
    from wildfire_ros.bag import read_messages

    topics = [f"/uav{k}/state_stamped" for k in range(n)]
    states: dict[str, dict[int, np.ndarray]] = {}
    for message in read_messages(bag, topics=topics):
        stamp, vector = stamped_state_from_msg(message.message)
        states.setdefault(message.topic, {})[stamp] = vector
    for k, topic in enumerate(topics):
        path = np.array([states[topic][t][:2] for t in sorted(states[topic])])
        np.testing.assert_array_equal(path, trajectory[:, k])


def test_lockstep_with_cameras_under_limited_links_equals_evaluate(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    # Every agent fuses its own reports and those it hears into its own filtered replica,
    # and the network decides on it. Loss and a 0.2 s delay make late reports (each replica
    # replays from a checkpoint); the outage ends in catch-ups whose replies carry reports.
    comm, policy, seed, n, duration = (
        "range=1500,loss=0.2,delay=2,outage=8-14",
        "belief-camera",
        2000011,
        3,
        25.0,
    )
    summary = fly_with_cameras(tmp_path, dds_env, policy, seed, n, duration, "--comm", comm)
    expected = fresh_evaluation(policy, camera_world(n, duration, comm=comm), seed, record=True)
    assert summary["comm"] == comm
    assert summary["score"] == expected.score > 0
    assert summary["decisions"] == expected.decisions
    assert summary["false_alarms"] == expected.false_alarms
    assert summary["belief_iou"] == expected.belief_iou
    links = summary["radio_links"]
    assert all(links[f"uav{k}"]["catch_ups"] >= 1 for k in range(n))
    assert_flight_paths(tmp_path / "bag", n, expected.trajectory)


def test_lockstep_of_the_camera_observation_network_equals_evaluate(
    tmp_path: Path, dds_env: dict[str, str]
) -> None:
    # Each agent makes its network's four camera images from the reports it just published,
    # as the environment does: every decision depends on its own noisy pixels.
    policy, seed, n, duration = "obs-camera", 2000005, 2, 10.0
    summary = fly_with_cameras(tmp_path, dds_env, policy, seed, n, duration)
    config = camera_world(n, duration)
    expected = fresh_evaluation(policy, config, seed, record=True)
    assert summary["score"] == summary["aggregator_score"] == expected.score > 0
    assert summary["decisions"] == expected.decisions
    assert summary["false_alarms"] == expected.false_alarms
    assert summary["belief_iou"] == expected.belief_iou
    assert_flight_paths(tmp_path / "bag", n, expected.trajectory)
