"""Bag -> transitions: a lockstep-style bag rebuilds exactly the environment's transitions."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from wildfire_learning.bag_transitions import (
    actions_from_banks,
    checked_actions,
    read_recording,
    rebuild_transitions,
    transitions_from_bags,
)
from wildfire_learning.errors import LearningError
from wildfire_learning.replay import ImageCodec
from wildfire_msgs_py import belief_codec, codecs, contract
from wildfire_ros.bag import BagWriter
from wildfire_ros.runtime import serialize_message as serialize
from wildfire_sim.episode import DECISIONS_PER_FIRE_STEP
from wildfire_world.env import EnvConfig, WildfireVecEnv

DECISION_NS = 100_000_000
WILDFIRE = str(Path(sys.executable).with_name("wildfire"))


class Rollout(NamedTuple):
    images: np.ndarray  # (T + 1, N, C, H, W) encoded
    states: np.ndarray  # (T + 1, N, K, 5)
    actions: np.ndarray  # (T, N)
    rewards: np.ndarray  # (T, N)
    terminated: bool


def _state(env: WildfireVecEnv, k: int) -> np.ndarray:
    a = env.aircraft
    return np.array([a.x_m[0, k], a.y_m[0, k], a.heading_rad[0, k], a.bank_rad[0, k]])


def record_rollout(
    bag: Path,
    config: EnvConfig,
    seed: int,
    decisions: int,
    *,
    start_pose: bool = True,
    bank_cmds: bool = True,
    actions: bool = False,
) -> Rollout:
    """Fly random actions and write what the nodes publish in lockstep mode."""
    env = WildfireVecEnv(config, 1)
    observations = env.reset([seed])
    codec = ImageCodec.for_approach(config.observation)
    rng = np.random.default_rng(seed)
    n = config.n_aircraft
    images, states, flown, rewards = (
        [codec.encode(observations["image"][0])],
        [observations["state"][0]],
        [],
        [],
    )
    with BagWriter(bag) as writer:
        for spec, latched in ((contract.FIRE_MAP, True), (contract.BELIEF, True)):
            writer.add_topic(spec.name, spec.type, transient_local=latched, depth=1)
        for k in range(n):
            writer.add_topic(contract.STATE.resolve(k), contract.STATE.type)
            if bank_cmds:
                writer.add_topic(contract.BANK_CMD.resolve(k), contract.BANK_CMD.type)
            if actions:
                writer.add_topic(contract.ACTION.resolve(k), contract.ACTION.type)
        writer.write(
            contract.FIRE_MAP.name, 1, serialize(codecs.fire_grid_to_msg(env.fire.burning[0], 0))
        )
        writer.write(
            contract.BELIEF.name, 2, serialize(belief_codec.belief_to_msg(env.belief.burning[0], 0))
        )
        if start_pose:
            for k in range(n):
                writer.write(
                    contract.STATE.resolve(k), 3, serialize(codecs.state_to_msg(_state(env, k)))
                )
        for t in range(1, decisions + 1):
            action = rng.integers(0, 2, size=(1, n))
            result = env.step(action)
            time_ns = t * DECISION_NS
            if t % DECISIONS_PER_FIRE_STEP == 0:
                # The simulator publishes the new fire before the agents report the tick.
                writer.write(
                    contract.FIRE_MAP.name,
                    time_ns,
                    serialize(codecs.fire_grid_to_msg(env.fire.burning[0], time_ns)),
                )
            for k in range(n):
                if bank_cmds:
                    writer.write(
                        contract.BANK_CMD.resolve(k),
                        time_ns + 1,
                        serialize(codecs.bank_cmd_to_msg(_state(env, k)[3])),
                    )
                if actions:
                    writer.write(
                        contract.ACTION.resolve(k),
                        time_ns + 1,
                        serialize(codecs.action_to_msg(action[0, k])),
                    )
                writer.write(
                    contract.STATE.resolve(k),
                    time_ns + 2,
                    serialize(codecs.state_to_msg(_state(env, k))),
                )
            images.append(codec.encode(result.observations["image"][0]))
            states.append(result.observations["state"][0])
            flown.append(action[0])
            rewards.append(result.rewards[0])
            if env.done[0]:
                break
    return Rollout(
        np.stack(images),
        np.stack(states),
        np.array(flown),
        np.array(rewards),
        bool(env.terminated[0]),
    )


@pytest.mark.parametrize("approach", ["obs", "belief"])
def test_rebuilt_transitions_equal_environment(tmp_path: Path, approach: str) -> None:
    config = EnvConfig(observation=approach, reward=approach, shapes=("circular", "arc"))
    rollout = record_rollout(tmp_path / "bag", config, seed=11, decisions=120)
    sequences = transitions_from_bags([tmp_path / "bag"], approach, config)
    assert [s.aircraft for s in sequences] == [0, 1]
    for k, sequence in enumerate(sequences):
        assert len(sequence.actions) == 120
        np.testing.assert_array_equal(sequence.actions, rollout.actions[:, k])
        np.testing.assert_array_equal(sequence.images, rollout.images[:, k])
        np.testing.assert_array_equal(sequence.states, rollout.states[:, k])
        np.testing.assert_array_equal(sequence.rewards, rollout.rewards[:, k])
        assert not sequence.terminated.any()
    if approach == "belief":
        # The team reward is not trivially zero: the rebuilt belief saw fire.
        assert sum(s.rewards.max() for s in sequences) > 0


def test_whole_episode_ends_terminal_and_missing_start_pose(tmp_path: Path) -> None:
    config = EnvConfig(shapes=("circular",), wind=(0.8, 0.8))
    rollout = record_rollout(tmp_path / "full", config, seed=3, decisions=4000)
    assert rollout.terminated
    sequences = transitions_from_bags([tmp_path / "full"], "obs", config)
    assert sequences[0].terminated[-1] == 1.0 and sequences[0].terminated[:-1].sum() == 0
    np.testing.assert_array_equal(sequences[1].rewards, rollout.rewards[:, 1])

    # Agents that publish states only after decisions: the first transition is lost.
    rollout = record_rollout(tmp_path / "late", config, seed=5, decisions=60, start_pose=False)
    recording = read_recording(tmp_path / "late", need_belief=False)
    assert recording.first_decision == 1
    sequences = rebuild_transitions(recording, "obs", config)
    np.testing.assert_array_equal(sequences[0].actions, rollout.actions[1:, 0])
    np.testing.assert_array_equal(sequences[0].images, rollout.images[1:, 0])
    np.testing.assert_array_equal(sequences[0].rewards, rollout.rewards[1:, 0])


def test_actions_without_bank_commands(tmp_path: Path) -> None:
    config = EnvConfig(shapes=("arc",))
    rollout = record_rollout(tmp_path / "bag", config, seed=8, decisions=40, bank_cmds=False)
    sequences = transitions_from_bags([tmp_path / "bag"], "obs", config)
    np.testing.assert_array_equal(sequences[1].actions, rollout.actions[:, 1])


@pytest.mark.parametrize("start_pose", [True, False])
def test_recorded_actions_are_taken_as_recorded(tmp_path: Path, start_pose: bool) -> None:
    config = EnvConfig(shapes=("circular",))
    rollout = record_rollout(
        tmp_path / "bag", config, seed=9, decisions=60, start_pose=start_pose, actions=True
    )
    recording = read_recording(tmp_path / "bag", need_belief=False)
    first = 0 if start_pose else 1
    assert recording.actions is not None and recording.first_decision == first
    np.testing.assert_array_equal(recording.actions, rollout.actions[first:])
    sequences = rebuild_transitions(recording, "obs", config)
    for k, sequence in enumerate(sequences):
        np.testing.assert_array_equal(sequence.actions, rollout.actions[first:, k])
        np.testing.assert_array_equal(sequence.rewards, rollout.rewards[first:, k])


def test_recorded_actions_must_match_the_banks() -> None:
    banks = np.array([[0, 10], [1, 10], [0, 9]])  # (T + 1, N) bank steps
    np.testing.assert_array_equal(
        checked_actions(np.array([[1, 1], [0, 0]]), banks), [[1, 1], [0, 0]]
    )
    with pytest.raises(LearningError, match="disagrees with the recorded banks"):
        checked_actions(np.array([[0, 1], [0, 0]]), banks)
    with pytest.raises(LearningError, match=r"outside 0\.\.1"):
        checked_actions(np.array([[2, 1], [0, 0]]), banks)


def test_actions_from_banks_at_the_limit() -> None:
    step = np.deg2rad(5.0)
    before = np.array([0.0, 3 * step, 10 * step, -10 * step, -10 * step])
    after = np.array([step, 2 * step, 10 * step, -10 * step, -9 * step])
    np.testing.assert_array_equal(actions_from_banks(before, after), [1, 0, 1, 0, 1])
    with pytest.raises(LearningError, match="one 5 degree step"):
        actions_from_banks(np.array([0.0]), np.array([2 * step]))


def test_bad_bags(tmp_path: Path) -> None:
    config = EnvConfig()
    with pytest.raises(LearningError, match="no such directory"):
        transitions_from_bags([tmp_path / "nope"], "obs", config)
    (tmp_path / "empty").mkdir()
    with pytest.raises(LearningError, match=r"metadata\.yaml"):
        transitions_from_bags([tmp_path / "empty"], "obs", config)
    with BagWriter(tmp_path / "other") as writer:
        writer.add_topic("/chatter", "std_msgs/msg/Float64")
        writer.write("/chatter", 1, serialize(codecs.float64_to_msg(1.0)))
    with pytest.raises(LearningError, match="missing topic /wildfire/fire_map"):
        transitions_from_bags([tmp_path / "other"], "obs", config)
    record_rollout(tmp_path / "ok", EnvConfig(), seed=1, decisions=30)
    mcap = next((tmp_path / "ok").glob("*.mcap"))
    mcap.write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    with pytest.raises(LearningError, match=r"corrupt|unreadable"):
        transitions_from_bags([tmp_path / "ok"], "obs", config)


def test_cli_trains_offline_from_a_bag(tmp_path: Path) -> None:
    config = EnvConfig(shapes=("circular",))
    rollout = record_rollout(tmp_path / "bag", config, seed=2, decisions=80)
    out = tmp_path / "from_bag.pt"
    command = [
        WILDFIRE,
        "train",
        "--approach",
        "obs",
        "--from-bag",
        str(tmp_path / "bag"),
        "--iterations",
        "5",
        "--batch-size",
        "8",
        "--eval-episodes",
        "1",
        "--episode-seconds",
        "3",
        "--run-dir",
        str(tmp_path / "run"),
        "--out",
        str(out),
        "--json",
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["transitions"] == 2 * len(rollout.actions) == 160
    assert summary["iterations"] == 5 and summary["samples"] == 0
    assert out.is_file() and out.with_suffix(".json").is_file()

    command[command.index("--run-dir") + 1] = str(tmp_path / "run2")
    missing = subprocess.run(
        [*command[:5], str(tmp_path / "nope"), *command[6:]],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert missing.returncode == 2
    assert missing.stderr.strip().count("\n") == 0 and "no such directory" in missing.stderr


def _replay_in_env(config: EnvConfig, seed: int, actions: np.ndarray) -> Rollout:
    """The environment's transitions for ``seed`` under given actions (T, N)."""
    env = WildfireVecEnv(config, 1)
    observations = env.reset([seed])
    codec = ImageCodec.for_approach(config.observation)
    images, states, rewards = (
        [codec.encode(observations["image"][0])],
        [observations["state"][0]],
        [],
    )
    for action in actions:
        result = env.step(action[None])
        images.append(codec.encode(result.observations["image"][0]))
        states.append(result.observations["state"][0])
        rewards.append(result.rewards[0])
    return Rollout(
        np.stack(images), np.stack(states), actions, np.array(rewards), bool(env.terminated[0])
    )


def _assert_bag_rebuilds_env(bag: Path, max_duration_s: float, decisions: int) -> None:
    """Both approaches' transitions rebuilt from a 2-aircraft recording of seed 7 equal the
    environment's under the recorded actions."""
    for approach in ("obs", "belief"):
        config = EnvConfig(
            observation=approach,
            reward=approach,
            shapes=("circular",),
            max_duration_s=max_duration_s,
        )
        sequences = transitions_from_bags([bag], approach, config)
        actions = np.stack([s.actions for s in sequences], axis=1)
        assert actions.shape == (decisions, 2)
        expected = _replay_in_env(config, 7, actions)
        for k, sequence in enumerate(sequences):
            np.testing.assert_array_equal(sequence.images, expected.images[:, k])
            np.testing.assert_array_equal(sequence.states, expected.states[:, k])
            np.testing.assert_array_equal(sequence.rewards, expected.rewards[:, k])


def test_bag_recorded_by_wildfire_run_rebuilds_environment_transitions(tmp_path: Path) -> None:
    """A real lockstep recording (`wildfire run --fast --record`) against the environment."""
    bag = tmp_path / "run"
    done = subprocess.run(
        [
            WILDFIRE,
            "run",
            "--aircraft",
            "2",
            "--policy",
            "random",
            "--seed",
            "7",
            "--duration",
            "6",
            "--fast",
            "--record",
            str(bag),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    _assert_bag_rebuilds_env(bag, max_duration_s=6.0, decisions=60)


@pytest.mark.dds
@pytest.mark.slow
@pytest.mark.timeout(900)
def test_belief_lockstep_recording_is_compact_and_rebuilds_every_transition(
    tmp_path: Path,
) -> None:
    """Bag size (issue 13; docs/ros2_layer.md, Tools): a 60 s 2-aircraft belief lockstep bag
    records at most 50 KB per sim second."""
    from mcap.reader import make_reader
    from rosbags.highlevel import AnyReader

    from wildfire_msgs_py.types import typestore
    from wildfire_ros.bag import BULKY_TOPICS, bag_info

    bag = tmp_path / "belief"
    done = subprocess.run(
        [
            *(WILDFIRE, "run", "--aircraft", "2", "--policy", "belief", "--seed", "7"),
            *("--duration", "60", "--fast", "--record", str(bag), "--json"),
        ],
        capture_output=True,
        text=True,
        timeout=880,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    size = sum(f.stat().st_size for f in bag.iterdir())
    assert size <= 50_000 * 60, f"{size / 60:.0f} bytes per simulated second"
    info = bag_info(bag)
    assert info.compression == "zstd" and info.time_source == "sim"
    assert not {t.name for t in info.topics} & set(BULKY_TOPICS)
    # Independent readers decode every message.
    with next(bag.glob("*.mcap")).open("rb") as stream:
        assert sum(1 for _ in make_reader(stream).iter_messages()) == info.message_count
    with AnyReader([bag], default_typestore=typestore()) as reader:
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
    _assert_bag_rebuilds_env(bag, max_duration_s=60.0, decisions=600)
