"""Persistent (epsilon-z-greedy) exploration: held random runs, random fraction epsilon."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_learning.exploration import PersistentExploration


def _random_fraction_and_runs(max_hold: int, epsilon: float) -> tuple[float, list[int]]:
    rng = np.random.default_rng(0)
    exploration = PersistentExploration(64, 2, max_hold)
    greedy = np.full((64, 2), 7)  # not an action: marks greedy decisions
    taken = np.stack([exploration.actions(greedy, epsilon, rng) for _ in range(2000)])
    random = taken != 7
    runs = []
    for track in random.reshape(2000, -1).T[:8]:
        edges = np.flatnonzero(np.diff(np.r_[0, track.astype(int), 0]))
        runs += list(edges[1::2] - edges[::2])
    return float(random.mean()), runs


@pytest.mark.parametrize(("max_hold", "epsilon"), [(1, 0.3), (20, 0.1), (20, 0.5)])
def test_random_fraction_is_epsilon(max_hold: int, epsilon: float) -> None:
    fraction, _ = _random_fraction_and_runs(max_hold, epsilon)
    assert fraction == pytest.approx(epsilon, abs=0.02)


def test_random_actions_are_held_in_runs() -> None:
    _, runs = _random_fraction_and_runs(20, 0.1)
    # Back-to-back runs merge, so a run can exceed 20; typical runs are long.
    assert np.mean(runs) > 8
    rng = np.random.default_rng(1)
    exploration = PersistentExploration(1, 1, 5)
    actions = [
        int(exploration.actions(np.zeros((1, 1), dtype=np.int64), 1.0, rng)[0, 0])
        for _ in range(200)
    ]
    # With epsilon 1 every decision is random, held for 1..5 decisions: runs of equal actions.
    changes = np.count_nonzero(np.diff(actions))
    assert changes < 200 / 2


def test_reset_ends_the_runs_of_new_episodes() -> None:
    exploration = PersistentExploration(2, 1, 20)
    exploration.actions(np.zeros((2, 1), dtype=np.int64), 1.0, np.random.default_rng(2))
    exploration.reset(np.array([1]))
    assert exploration.hold_left[1, 0] == 0
