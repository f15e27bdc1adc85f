"""Memory-lean experience replay for the pairwise Q-network.

Two rings share the memory:

* a **frame ring** of observations — the image quantised to uint8 (:class:`ImageCodec`) and
  the normalised pairwise states (K, 5) float32 — each written once;
* a **transition ring** of ``(obs frame id, action, reward, terminated, next frame id,
  steps)``, where ``steps`` is how many decisions the transition spans: an n-step transition
  holds the discounted sum of its ``steps`` rewards and bootstraps with ``gamma ** steps``.

A frame may also hold a teacher's label: the action a privileged planner would take from
that observation (``teacher.py``), or :data:`NO_LABEL`.

Each transition has a priority, used only by prioritised sampling (Schaul et al. 2016,
proportional): it is drawn with probability ``priority ** alpha / sum``, and its Bellman error
weighted by ``(N * probability) ** -beta`` over the mini-batch's largest such weight (as
Dopamine's Rainbow does; over the whole ring's, as in the paper, one nearly-learnt transition
would scale every step down). A new transition gets the largest priority yet, so it is
replayed soon; a replayed one gets its absolute Bellman error
(:meth:`ReplayBuffer.update_priorities`). The draw is one cumulative sum and a binary search
over the ring per mini-batch (1.6 ms at 70 000 here, against 0.4 ms uniform): no sum tree
is needed at this size, next to a training iteration of ~100 ms.

A decision's next observation is the next decision's observation, so storing frames once
halves the memory of a CleanRL-style ``(obs, next_obs)`` buffer. Frame ids are global write
counters: a transition is valid while both its frames are still in the frame ring (checked at
sampling time, invalid draws are redrawn). The frame ring is a little larger than the
transition ring because every episode start writes one frame without a transition.

Quantisation: every image channel ``c`` is stored as ``round(value * scale[c])`` and read
back as ``stored / scale[c]``. The observation image is binary (scale 1, exact); under camera
sensing its four camera images are 0, 0.5 or 1 (scale 2, exact). The belief
image is (probability of burning, age / 255): the probability in whole percent (scale 100,
exact: the shared belief is published in whole percent, and is 0 or 1 under the disc); age
in whole seconds (scale 255), i.e. to within 0.5 s — a deliberate, documented approximation
of training inputs (the deployed network sees 0.1 s resolution).

Memory at capacity 70 000: observation approach 70 000 x 1.2 kB = 84 MB; belief approach
70 000 x 20 kB = 1.4 GB.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch

from wildfire_agent.approaches import Approach
from wildfire_agent.camera_view import IMAGE_SCALE
from wildfire_belief.sensors import NUM_CAMERAS
from wildfire_learning.errors import LearningError

OBS_SCALES = (1.0,)
"""Quantisation scale of the sensor image (binary)."""
CAMERA_SCALE = IMAGE_SCALE
"""Quantisation scale of each camera image: pixels are 0, 0.5 or 1, stored 0, 1, 2 (exact)."""
PRIORITY_FLOOR = 1e-4
"""Added to a replayed transition's absolute Bellman error (Q units): none is never drawn."""
NO_LABEL = -1
"""The label of a frame no teacher labelled (a bag's, a run without teacher)."""
BELIEF_SCALES = (100.0, 255.0)
"""Quantisation scales of the belief image: the probability of burning in whole percent (as
the shared belief carries it; 0 or 100 under the disc), age / 255 -> whole seconds."""


@dataclass(frozen=True)
class ImageCodec:
    """float32 images (C, H, W) <-> uint8, channel ``c`` stored as ``round(x * scales[c])``."""

    scales: tuple[float, ...]

    @classmethod
    def for_approach(cls, approach: str, sensor: str = "disc") -> ImageCodec:
        """The codec of ``approach``'s images in a world sensed by ``sensor``."""
        if approach == Approach.BELIEF:
            return cls(BELIEF_SCALES)
        if sensor == "camera":
            return cls((CAMERA_SCALE,) * NUM_CAMERAS)
        return cls(OBS_SCALES)

    def encode(self, images: np.ndarray) -> np.ndarray:
        """(..., C, H, W) float -> uint8."""
        scale = np.asarray(self.scales, dtype=np.float32)[:, None, None]
        return np.rint(np.asarray(images, dtype=np.float32) * scale).clip(0, 255).astype(np.uint8)

    def decode(self, encoded: torch.Tensor) -> torch.Tensor:
        """(B, C, H, W) uint8 tensor -> float32 tensor (on the device of ``encoded``)."""
        # A division, not a multiplication by 1 / scale: correctly rounded, so a whole percent
        # reads back as exactly the float32 the environment showed (percent / 100).
        scales = torch.tensor(self.scales, dtype=torch.float32, device=encoded.device)
        return encoded.to(torch.float32) / scales[:, None, None]


class Batch(NamedTuple):
    """A mini-batch of transitions as tensors."""

    images: torch.Tensor
    """(B, C, H, W) float32."""
    states: torch.Tensor
    """(B, K, 5) float32."""
    actions: torch.Tensor
    """(B,) int64."""
    rewards: torch.Tensor
    """(B,) float32."""
    terminated: torch.Tensor
    """(B,) float32: 1 when the episode ended by termination (no bootstrap)."""
    next_images: torch.Tensor
    next_states: torch.Tensor
    steps: torch.Tensor
    """(B,) float32: decisions spanned (the bootstrap is discounted by gamma ** steps)."""
    labels: torch.Tensor
    """(B,) int64: the teacher's action from the observation, or :data:`NO_LABEL`."""
    weights: torch.Tensor
    """(B,) float32: importance weight of each Bellman error (1 under uniform sampling)."""
    slots: np.ndarray
    """(B,) int64: where the transitions lie, for :meth:`ReplayBuffer.update_priorities`."""


class ReplayBuffer:
    """Transition ring over a frame ring (see the module docstring)."""

    def __init__(
        self,
        capacity: int,
        image_shape: tuple[int, int, int],
        state_shape: tuple[int, int],
        codec: ImageCodec,
        frame_capacity: int | None = None,
    ) -> None:
        if capacity < 1:
            raise LearningError(f"replay capacity: expected >= 1, got {capacity}")
        self.capacity = capacity
        # Each episode start costs a frame with no transition; 5 % slack covers episodes of
        # 20+ decisions, and a too-old frame only makes its transition unsampleable.
        self.frame_capacity = frame_capacity or capacity + max(capacity // 20, 64)
        self.codec = codec
        self.image_shape = tuple(image_shape)
        self.state_shape = tuple(state_shape)
        self.images = np.zeros((self.frame_capacity, *image_shape), dtype=np.uint8)
        self.states = np.zeros((self.frame_capacity, *state_shape), dtype=np.float32)
        self.labels = np.full(self.frame_capacity, NO_LABEL, dtype=np.int8)
        self.obs_id = np.zeros(capacity, dtype=np.int64)
        self.next_id = np.zeros(capacity, dtype=np.int64)
        self.actions = np.zeros(capacity, dtype=np.int64)
        self.rewards = np.zeros(capacity, dtype=np.float32)
        self.terminated = np.zeros(capacity, dtype=np.float32)
        self.steps = np.ones(capacity, dtype=np.uint8)
        self.priorities = np.ones(capacity, dtype=np.float32)
        self.max_priority = 1.0
        self.frames_written = 0
        self.transitions_written = 0

    def __len__(self) -> int:
        return min(self.transitions_written, self.capacity)

    @property
    def nbytes(self) -> int:
        arrays = (
            self.images,
            self.states,
            self.labels,
            self.obs_id,
            self.next_id,
            self.actions,
            self.rewards,
            self.terminated,
            self.steps,
            self.priorities,
        )
        return sum(a.nbytes for a in arrays)

    def add_frames(
        self,
        images: np.ndarray,
        states: np.ndarray,
        encoded: bool = False,
        labels: np.ndarray | None = None,
    ) -> np.ndarray:
        """Store observations (P, C, H, W) and (P, K, 5), with their teacher's labels (P,) if
        any; return their global frame ids (P,)."""
        count = len(states)
        ids = self.frames_written + np.arange(count, dtype=np.int64)
        slots = ids % self.frame_capacity
        self.images[slots] = images if encoded else self.codec.encode(images)
        self.states[slots] = states
        self.labels[slots] = NO_LABEL if labels is None else labels
        self.frames_written += count
        return ids

    def add_transitions(
        self,
        obs_ids: np.ndarray,
        actions: np.ndarray,
        rewards: np.ndarray,
        terminated: np.ndarray | float,
        next_ids: np.ndarray,
        steps: np.ndarray | int = 1,
    ) -> None:
        """Store transitions between frames already added (``steps`` decisions each)."""
        count = len(obs_ids)
        slots = (self.transitions_written + np.arange(count)) % self.capacity
        self.obs_id[slots] = obs_ids
        self.next_id[slots] = next_ids
        self.actions[slots] = actions
        self.rewards[slots] = rewards
        self.terminated[slots] = terminated
        self.steps[slots] = steps
        self.priorities[slots] = self.max_priority
        self.transitions_written += count

    def add_sequence(
        self,
        images: np.ndarray,
        states: np.ndarray,
        actions: np.ndarray,
        rewards: np.ndarray,
        terminated: np.ndarray,
        encoded: bool = False,
    ) -> None:
        """Store one aircraft's trajectory: T + 1 observations and T transitions."""
        ids = self.add_frames(images, states, encoded=encoded)
        self.add_transitions(ids[:-1], actions, rewards, terminated, ids[1:])

    def _valid(self, slots: np.ndarray) -> np.ndarray:
        oldest_kept = self.frames_written - self.frame_capacity
        return self.obs_id[slots] >= oldest_kept

    def sample(
        self,
        batch_size: int,
        rng: np.random.Generator,
        device: torch.device | None = None,
        alpha: float = 0.0,
        beta: float = 0.0,
    ) -> Batch:
        """A mini-batch of stored transitions whose frames are still kept, as tensors on
        ``device`` (default CPU); images travel as uint8 and are decoded there. Uniform when
        ``alpha`` is 0, else prioritised with exponents ``alpha`` and ``beta`` (module
        docstring)."""
        size = len(self)
        if size == 0:
            raise LearningError("replay: cannot sample from an empty buffer")
        if alpha > 0:
            slots, weights = self._prioritised(batch_size, rng, alpha, beta)
        else:
            slots, weights = self._uniform(batch_size, rng), np.ones(batch_size, np.float32)
        obs = self.obs_id[slots] % self.frame_capacity
        nxt = self.next_id[slots] % self.frame_capacity
        device = device or torch.device("cpu")

        def tensor(array: np.ndarray) -> torch.Tensor:
            # Pinned memory would speed a CUDA copy a little; not worth a CUDA-only path.
            return torch.from_numpy(array).to(device)

        decode = self.codec.decode
        return Batch(
            images=decode(tensor(self.images[obs])),
            states=tensor(self.states[obs]),
            actions=tensor(self.actions[slots]),
            rewards=tensor(self.rewards[slots]),
            terminated=tensor(self.terminated[slots]),
            next_images=decode(tensor(self.images[nxt])),
            next_states=tensor(self.states[nxt]),
            steps=tensor(self.steps[slots].astype(np.float32)),
            labels=tensor(self.labels[obs].astype(np.int64)),
            weights=tensor(weights),
            slots=slots,
        )

    def _uniform(self, batch_size: int, rng: np.random.Generator) -> np.ndarray:
        slots = rng.integers(0, len(self), batch_size)
        for _ in range(100):
            bad = ~self._valid(slots)
            if not bad.any():
                break
            slots[bad] = rng.integers(0, len(self), int(bad.sum()))
        return slots

    def _prioritised(
        self, batch_size: int, rng: np.random.Generator, alpha: float, beta: float
    ) -> tuple[np.ndarray, np.ndarray]:
        size = len(self)
        mass = self.priorities[:size] ** np.float32(alpha)  # float32: 3x faster than float64
        mass[~self._valid(np.arange(size))] = 0.0  # frames overwritten: probability 0
        cumulative = np.cumsum(mass, dtype=np.float64)
        total = cumulative[-1]
        if not total > 0:
            raise LearningError("replay: no transition with both frames kept")
        slots = np.searchsorted(cumulative, rng.random(batch_size) * total, side="right")
        slots = np.minimum(slots, size - 1)
        weights = (np.count_nonzero(mass) * mass[slots] / total) ** -beta
        return slots, (weights / weights.max()).astype(np.float32)

    def update_priorities(self, slots: np.ndarray, errors: np.ndarray) -> None:
        """Set the priorities of replayed transitions to their absolute Bellman errors."""
        priorities = np.abs(errors).astype(np.float32) + PRIORITY_FLOOR
        self.priorities[slots] = priorities
        self.max_priority = max(self.max_priority, float(priorities.max()))

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> None:
        """Write the whole buffer to ``path`` (.npz, uncompressed: fast, and images are uint8)."""
        np.savez(
            path,
            images=self.images,
            states=self.states,
            labels=self.labels,
            obs_id=self.obs_id,
            next_id=self.next_id,
            actions=self.actions,
            rewards=self.rewards,
            terminated=self.terminated,
            steps=self.steps,
            priorities=self.priorities,
            max_priority=np.float64(self.max_priority),
            counters=np.array([self.frames_written, self.transitions_written], dtype=np.int64),
            scales=np.asarray(self.codec.scales, dtype=np.float64),
        )

    @classmethod
    def load(cls, path: str | Path) -> ReplayBuffer:
        """Read a buffer written by :meth:`save`."""
        try:
            with np.load(path) as data:
                images, states = data["images"], data["states"]
                buffer = cls(
                    capacity=len(data["obs_id"]),
                    image_shape=images.shape[1:],
                    state_shape=states.shape[1:],
                    codec=ImageCodec(tuple(float(s) for s in data["scales"])),
                    frame_capacity=len(images),
                )
                buffer.images[:] = images
                buffer.states[:] = states
                for name in ("obs_id", "next_id", "actions", "rewards", "terminated"):
                    getattr(buffer, name)[:] = data[name]
                if "steps" in data:  # replays saved before n-step targets hold one-step ones
                    buffer.steps[:] = data["steps"]
                if "labels" in data:  # replays saved before teachers hold no label
                    buffer.labels[:] = data["labels"]
                if "priorities" in data:  # before prioritised replay: all alike
                    buffer.priorities[:] = data["priorities"]
                    buffer.max_priority = float(data["max_priority"])
                buffer.frames_written, buffer.transitions_written = (
                    int(v) for v in data["counters"]
                )
        except (OSError, KeyError, ValueError) as error:
            raise LearningError(f"replay file {path}: unreadable ({error})") from None
        return buffer


__all__ = [
    "BELIEF_SCALES",
    "NO_LABEL",
    "OBS_SCALES",
    "PRIORITY_FLOOR",
    "Batch",
    "ImageCodec",
    "ReplayBuffer",
]
