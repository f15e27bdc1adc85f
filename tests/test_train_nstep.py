"""n-step accumulation: every decision becomes one transition with the right return."""

from __future__ import annotations

import numpy as np
import pytest

from wildfire_learning.nstep import NStepAccumulator

GAMMA = 0.9


def _play(
    episode_lengths: list[int], n_aircraft: int, n_step: int, terminating: set[int]
) -> tuple[list[tuple], list[tuple]]:
    """Feed random decisions of one episode per environment; return (released, expected)."""
    rng = np.random.default_rng(0)
    num_envs = len(episode_lengths)
    accumulator = NStepAccumulator(num_envs, n_aircraft, n_step, GAMMA)
    frame = np.arange(num_envs * n_aircraft).reshape(num_envs, n_aircraft)
    next_frame_id = frame.size
    history: dict[int, list[tuple]] = {e: [] for e in range(num_envs)}
    done = np.zeros(num_envs, dtype=bool)
    released: list[tuple] = []
    while not done.all():
        active = np.flatnonzero(~done)
        actions = rng.integers(0, 2, (active.size, n_aircraft))
        rewards = rng.random((active.size, n_aircraft))
        next_ids = next_frame_id + np.arange(active.size * n_aircraft).reshape(-1, n_aircraft)
        next_frame_id += next_ids.size
        ended = np.array([len(history[e]) + 1 == episode_lengths[e] for e in active])
        terminated = ended & np.isin(active, list(terminating))
        for row, env in enumerate(active):
            history[env].append((frame[env].copy(), actions[row], rewards[row], next_ids[row]))
        ready = accumulator.push(
            active, frame[active], actions, rewards, next_ids, terminated, ended
        )
        released += [tuple(float(v) for v in row) for row in zip(*ready, strict=True)]
        frame[active] = next_ids
        done[active] |= ended

    expected = []
    for env, steps in history.items():
        for t in range(len(steps)):
            last = min(t + n_step, len(steps))
            for k in range(n_aircraft):
                ret = sum(GAMMA ** (j - t) * steps[j][2][k] for j in range(t, last))
                end = float(env in terminating and last == len(steps))
                expected.append(
                    (
                        float(steps[t][0][k]),
                        float(steps[t][1][k]),
                        ret,
                        end,
                        float(steps[last - 1][3][k]),
                        float(last - t),
                    )
                )
    return released, expected


@pytest.mark.parametrize("n_step", [1, 4])
def test_every_decision_is_released_once_with_its_n_step_return(n_step: int) -> None:
    released, expected = _play([7, 2, 11], n_aircraft=2, n_step=n_step, terminating={0})
    assert len(released) == len(expected) == 2 * (7 + 2 + 11)
    released.sort()
    expected.sort()
    for got, want in zip(released, expected, strict=True):
        assert got[:2] == want[:2] and got[3:] == want[3:]
        assert got[2] == pytest.approx(want[2], rel=1e-12)


def test_one_step_accumulator_releases_at_once() -> None:
    accumulator = NStepAccumulator(1, 2, 1, GAMMA)
    ready = accumulator.push(
        np.array([0]),
        np.array([[0, 1]]),
        np.array([[1, 0]]),
        np.array([[0.5, -1.0]]),
        np.array([[2, 3]]),
        np.array([False]),
        np.array([False]),
    )
    np.testing.assert_array_equal(ready.next_ids, [2, 3])
    np.testing.assert_array_equal(ready.rewards, [0.5, -1.0])
    np.testing.assert_array_equal(ready.steps, [1, 1])
