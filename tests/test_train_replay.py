"""Replay buffer: quantisation, frame sharing, overwrite, save/load round trip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from wildfire_learning.errors import LearningError
from wildfire_learning.replay import ImageCodec, ReplayBuffer


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
    buffer.save(tmp_path / "replay.npz")
    loaded = ReplayBuffer.load(tmp_path / "replay.npz")
    assert (loaded.frames_written, loaded.transitions_written) == (52, 48)
    assert loaded.codec == buffer.codec and loaded.frame_capacity == buffer.frame_capacity
    a = buffer.sample(16, np.random.default_rng(9))
    b = loaded.sample(16, np.random.default_rng(9))
    for x, y in zip(a, b, strict=True):
        torch.testing.assert_close(x, y, rtol=0, atol=0)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(LearningError, match="unreadable"):
        ReplayBuffer.load(tmp_path / "bad.npz")
