"""Replay buffer: quantisation, frame sharing, overwrite, save/load round trip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from wildfire_learning.errors import LearningError
from wildfire_learning.replay import PRIORITY_FLOOR, ImageCodec, ReplayBuffer
from wildfire_learning.train_config import TrainConfig


def _sequence(rng: np.random.Generator, length: int, shape: tuple[int, ...]) -> tuple:
    images = (rng.random((length + 1, *shape)) < 0.3).astype(np.float32)
    states = rng.standard_normal((length + 1, 1, 5)).astype(np.float32)
    actions = rng.integers(0, 2, length)
    rewards = rng.standard_normal(length)
    terminated = np.zeros(length, dtype=np.float32)
    terminated[-1] = 1.0
    return images, states, actions, rewards, terminated


def test_belief_codec_keeps_burning_exact_and_age_to_half_a_second() -> None:
    codec = ImageCodec.for_approach("belief")
    rng = np.random.default_rng(0)
    image = np.stack([rng.random((100, 100)) < 0.5, rng.integers(0, 2551, (100, 100)) / 2550.0])
    decoded = codec.decode(torch.from_numpy(codec.encode(image[None])))[0].numpy()
    np.testing.assert_array_equal(decoded[0], image[0])
    assert np.abs(decoded[1] - image[1]).max() * 255.0 <= 0.5 + 1e-4
    assert codec.encode(image[None]).dtype == np.uint8


def test_sample_returns_the_stored_pairs() -> None:
    rng = np.random.default_rng(1)
    images, states, actions, rewards, terminated = _sequence(rng, 50, (1, 30, 40))
    buffer = ReplayBuffer(100, (1, 30, 40), (1, 5), ImageCodec.for_approach("obs"))
    buffer.add_sequence(images, states, actions, rewards, terminated)
    assert len(buffer) == 50 and buffer.frames_written == 51
    batch = buffer.sample(256, np.random.default_rng(2))
    for i in range(256):
        # Identify the transition by its state, then check every field against the source.
        t = int(np.flatnonzero((states[:-1, 0] == batch.states[i, 0].numpy()).all(axis=1))[0])
        np.testing.assert_array_equal(batch.images[i].numpy(), images[t])
        np.testing.assert_array_equal(batch.next_images[i].numpy(), images[t + 1])
        np.testing.assert_array_equal(batch.next_states[i].numpy(), states[t + 1])
        assert batch.actions[i] == actions[t]
        assert batch.rewards[i] == np.float32(rewards[t])
        assert batch.terminated[i] == terminated[t]


def test_overwritten_frames_are_never_sampled() -> None:
    rng = np.random.default_rng(3)
    buffer = ReplayBuffer(20, (1, 4, 4), (1, 5), ImageCodec.for_approach("obs"), frame_capacity=22)
    for _ in range(10):  # 10 episodes of 5 decisions: 60 frames, 50 transitions
        buffer.add_sequence(*_sequence(rng, 5, (1, 4, 4)))
    assert len(buffer) == 20
    slots = np.arange(20)
    valid = buffer._valid(slots)
    # Frames older than the last 22 are gone: the oldest transitions are invalid...
    assert not valid.all() and valid.any()
    batch = buffer.sample(500, np.random.default_rng(4))
    oldest_kept = buffer.frames_written - buffer.frame_capacity
    kept_states = buffer.states[
        np.arange(oldest_kept, buffer.frames_written) % buffer.frame_capacity
    ]
    # ...and every sampled observation is one of the kept frames.
    for state in batch.states.numpy()[:, 0]:
        assert (kept_states[:, 0] == state).all(axis=1).any()


def test_save_load_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    buffer = ReplayBuffer(30, (2, 8, 8), (1, 5), ImageCodec.for_approach("belief"))
    for _ in range(4):
        buffer.add_sequence(*_sequence(rng, 12, (2, 8, 8)))
    buffer.update_priorities(np.arange(10), np.linspace(0.0, 3.0, 10))
    buffer.save(tmp_path / "replay.npz")
    loaded = ReplayBuffer.load(tmp_path / "replay.npz")
    assert (loaded.frames_written, loaded.transitions_written) == (52, 48)
    assert loaded.codec == buffer.codec and loaded.frame_capacity == buffer.frame_capacity
    assert loaded.max_priority == buffer.max_priority
    for exponents in ((0.0, 0.0), (0.6, 0.4)):  # uniform, prioritised
        a = buffer.sample(16, np.random.default_rng(9), None, *exponents)
        b = loaded.sample(16, np.random.default_rng(9), None, *exponents)
        for x, y in zip(a, b, strict=True):
            torch.testing.assert_close(x, y, rtol=0, atol=0)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(LearningError, match="unreadable"):
        ReplayBuffer.load(tmp_path / "bad.npz")


def test_prioritised_draws_follow_the_priorities_and_weigh_them_back() -> None:
    buffer = ReplayBuffer(100, (1, 4, 4), (1, 5), ImageCodec.for_approach("obs"))
    buffer.add_sequence(*_sequence(np.random.default_rng(6), 4, (1, 4, 4)))
    # New transitions share the largest priority yet; a replayed one gets its error.
    assert buffer.priorities[:4].tolist() == [1.0] * 4
    buffer.update_priorities(np.arange(4), np.array([0.5, -1.0, 2.0, 1.0]))
    np.testing.assert_allclose(buffer.priorities[:4], np.array([0.5, 1, 2, 1]) + PRIORITY_FLOOR)
    assert buffer.max_priority == pytest.approx(2.0 + PRIORITY_FLOOR)
    buffer.add_sequence(*_sequence(np.random.default_rng(7), 1, (1, 4, 4)))
    assert buffer.priorities[4] == np.float32(buffer.max_priority)
    # alpha = 1: probabilities 0.5 : 1 : 2 : 1 : 2 (out of 6.5), the floor aside.
    batch = buffer.sample(60_000, np.random.default_rng(8), None, 1.0, 1.0)
    counts = np.bincount(batch.slots, minlength=5) / 60_000
    np.testing.assert_allclose(counts, np.array([0.5, 1, 2, 1, 2]) / 6.5, atol=0.01)
    # beta = 1 undoes the skew: weight 1 / (N P), over the largest (the least likely drawn).
    weights = dict(zip(batch.slots.tolist(), batch.weights.tolist(), strict=True))
    assert weights[0] == 1.0 and weights[1] == weights[3] == pytest.approx(0.5, rel=1e-3)
    assert weights[2] == weights[4] == pytest.approx(0.25, rel=1e-3)
    # alpha = 0: uniform, every weight 1.
    uniform = buffer.sample(64, np.random.default_rng(8))
    assert uniform.weights.tolist() == [1.0] * 64


def test_prioritised_draws_skip_overwritten_frames() -> None:
    rng = np.random.default_rng(3)
    buffer = ReplayBuffer(20, (1, 4, 4), (1, 5), ImageCodec.for_approach("obs"), frame_capacity=22)
    for _ in range(10):
        buffer.add_sequence(*_sequence(rng, 5, (1, 4, 4)))
    invalid = np.flatnonzero(~buffer._valid(np.arange(20)))
    buffer.update_priorities(invalid, np.full(len(invalid), 100.0))  # tempting, but gone
    batch = buffer.sample(500, np.random.default_rng(4), None, 0.6, 0.4)
    assert not np.isin(batch.slots, invalid).any()


def test_prioritised_replay_s_beta_rises_to_one_over_the_run() -> None:
    config = TrainConfig(prioritized=True, iterations=100)
    assert config.priority_exponents_at(0) == (0.6, 0.4)
    assert config.priority_exponents_at(50)[1] == pytest.approx(0.7)
    assert config.priority_exponents_at(100)[1] == config.priority_exponents_at(500)[1] == 1.0
    assert TrainConfig(iterations=100).priority_exponents_at(50) == (0.0, 0.0)  # uniform
    with pytest.raises(LearningError, match="priority_beta in"):
        TrainConfig(prioritized=True, priority_beta=1.5).validate()
