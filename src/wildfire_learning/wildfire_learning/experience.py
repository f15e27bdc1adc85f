"""Where the replay's transitions come from: the training episodes of a run, and recorded bags.

:class:`TrainingEpisodes` steps ``num_envs`` episodes together. Every observation goes into the
replay once, as a frame (uint8) that transitions refer to by id, so an n-step transition costs
no image copy. Every aircraft's decisions go through an n-step accumulator, which releases a
transition once its n rewards are known or its episode has ended. An episode that ends restarts
at once on the next training seed (seeds count up from 0, wrapping below the validation seeds),
so every step is a full batch. With a teacher (``--teacher``, ``teacher.py``) each new frame
is stored with the teacher's label, while the teacher's loss still has weight.

Bags (``--from-bag``) give whole sequences rebuilt by ``bag_transitions.py``; a new replay
holds them before any episode's transition.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from wildfire_learning.errors import LearningError
from wildfire_learning.evaluate import VALIDATION_SEED_BASE
from wildfire_learning.exploration import PersistentExploration
from wildfire_learning.nstep import NStepAccumulator
from wildfire_learning.replay import NO_LABEL, ImageCodec, ReplayBuffer
from wildfire_learning.teacher import make_teacher
from wildfire_learning.train_config import TrainConfig, TrainState, replay_shapes
from wildfire_world.env import WildfireVecEnv

if TYPE_CHECKING:  # the bag reader (rosbags) loads only for runs that read bags
    from wildfire_learning.bag_transitions import RebuiltSequence


def new_replay(
    config: TrainConfig, capacity: int, sequences: list[RebuiltSequence]
) -> ReplayBuffer:
    """An empty replay of ``capacity`` transitions, then ``sequences`` stored in it."""
    image_shape, state_shape = replay_shapes(config)
    codec = ImageCodec.for_approach(config.approach, config.sensor)
    replay = ReplayBuffer(capacity, image_shape, state_shape, codec)
    for sequence in sequences:
        replay.add_sequence(
            sequence.images,
            sequence.states,
            sequence.actions,
            sequence.rewards,
            sequence.terminated,
            encoded=True,
        )
    return replay


def bag_sequences(config: TrainConfig, bag_dirs: tuple[Path, ...]) -> list[RebuiltSequence]:
    """Transitions rebuilt from ``bag_dirs`` (none without bags)."""
    if not bag_dirs:
        return []
    if config.reward_kind() != config.approach:
        # The rebuild scores a bag with the approach's own reward (bag_transitions.py).
        raise LearningError(
            f"--from-bag: the bags rebuild the {config.approach} approach's own reward "
            f"(expected --reward approach, got {config.reward})"
        )
    # The bag reader (rosbags) loads only for runs that read bags.
    from wildfire_learning.bag_transitions import transitions_from_bags

    sequences = transitions_from_bags(bag_dirs, config.approach, config.env_config())
    if sum(len(s.actions) for s in sequences) == 0:
        raise LearningError("--from-bag: the bags hold no complete decision to learn from")
    return sequences


def next_training_seeds(state: TrainState, count: int) -> np.ndarray:
    """Seeds of the next ``count`` training episodes (below the validation seeds)."""
    seeds = (state.episodes + np.arange(count)) % VALIDATION_SEED_BASE
    state.episodes += count
    return seeds


def flat_aircraft(
    observations: dict[str, np.ndarray], envs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Images (P, C, H, W) and states (P, K, 5) of every aircraft of ``envs``, env-major."""
    images, states = observations["image"][envs], observations["state"][envs]
    return (images.reshape(-1, *images.shape[2:]), states.reshape(-1, *states.shape[2:]))


class TrainingEpisodes:
    """The episodes of an online run, and what the loop carries between decisions."""

    def __init__(
        self,
        config: TrainConfig,
        replay: ReplayBuffer,
        state: TrainState,
        rng: np.random.Generator,
    ) -> None:
        self.config = config
        self.n_aircraft = config.n_aircraft
        self.everyone = np.arange(config.num_envs)
        self.teacher = None if config.teacher == "none" else make_teacher(config.teacher, rng)
        self.env = WildfireVecEnv(config.env_config(), config.num_envs)
        self.observations = self.env.reset(next_training_seeds(state, config.num_envs))
        frame_ids = self._add_frames(replay, state, self.everyone)
        self.frame_ids = frame_ids.reshape(config.num_envs, config.n_aircraft)
        """(E, N) replay frame of every aircraft's current observation."""
        self.pending = NStepAccumulator(
            config.num_envs, config.n_aircraft, config.n_step, config.gamma
        )
        self.exploration = PersistentExploration(
            config.num_envs, config.n_aircraft, config.explore_hold
        )

    def _add_frames(self, replay: ReplayBuffer, state: TrainState, envs: np.ndarray) -> np.ndarray:
        """Store the current observations of ``envs``' aircraft, labelled by the teacher while
        its loss has weight (an episode that has just ended is not: its last observation is
        only ever a next one); return their frame ids (E * N,)."""
        labels = None
        if self.teacher is not None and self.config.teacher_weight_at(state.iterations) > 0:
            per_env = np.full((len(envs), self.n_aircraft), NO_LABEL, dtype=np.int8)
            running = ~self.env.done[envs]
            labelled = self.teacher.labels(self.env, envs[running])
            per_env[running] = labelled.reshape(-1, self.n_aircraft)
            labels = per_env.reshape(-1)
        return replay.add_frames(*flat_aircraft(self.observations, envs), labels=labels)

    def aircraft(self) -> tuple[np.ndarray, np.ndarray]:
        """Current images and pairwise states of every aircraft, env-major (one batch)."""
        return flat_aircraft(self.observations, self.everyone)

    def step(self, actions: np.ndarray, replay: ReplayBuffer, state: TrainState) -> int:
        """Step the running episodes with ``actions`` (E, N); store the new frames and the
        transitions now complete in ``replay``; restart the episodes that ended on the next
        training seeds (counted in ``state.episodes``). Return the aircraft decisions taken."""
        n, env = self.n_aircraft, self.env
        active = np.flatnonzero(~env.done)
        result = env.step(actions)
        self.observations = result.observations
        next_ids = self._add_frames(replay, state, active)
        next_ids = next_ids.reshape(-1, n)
        ready = self.pending.push(
            active,
            self.frame_ids[active],
            actions[active],
            result.rewards[active],
            next_ids,
            result.terminated[active],
            env.done[active],
        )
        replay.add_transitions(
            ready.obs_ids,
            ready.actions,
            ready.rewards,
            ready.terminated,
            ready.next_ids,
            ready.steps,
        )
        self.frame_ids[active] = next_ids
        ended = np.flatnonzero(env.done)
        if ended.size:
            self.observations = env.reset(next_training_seeds(state, int(ended.size)), ended)
            self.exploration.reset(ended)
            ended_ids = self._add_frames(replay, state, ended)
            self.frame_ids[ended] = ended_ids.reshape(-1, n)
        return int(active.size) * n


__all__ = [
    "TrainingEpisodes",
    "bag_sequences",
    "flat_aircraft",
    "new_replay",
    "next_training_seeds",
]
