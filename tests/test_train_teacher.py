"""The privileged teacher of ``wildfire train --teacher``: its labels are the planner's own
choices, they travel with their frames through the replay, and the margin loss teaches them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from wildfire_agent.policy_names import BELIEF_PLANNER
from wildfire_learning.architectures import build_q_network
from wildfire_learning.dqn import td_update
from wildfire_learning.errors import LearningError
from wildfire_learning.experience import TrainingEpisodes, new_replay
from wildfire_learning.oracle import OracleConfig, known_future, plan_episode
from wildfire_learning.replay import NO_LABEL, ImageCodec, ReplayBuffer
from wildfire_learning.teacher import OracleTeacher, PlannerTeacher, margin_loss
from wildfire_learning.train_config import TrainConfig, TrainState
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_sim.seeding import Stream, generator
from wildfire_world.env import EnvConfig, WildfireVecEnv


def test_margin_loss_is_zero_once_the_label_leads_by_the_margin() -> None:
    q = torch.tensor([[1.0, 0.5], [0.0, 0.0], [2.0, 3.0], [0.3, 0.35]])
    labels = torch.tensor([0, 1, NO_LABEL, 1])
    # Row 0 leads by 0.5 >= 0.1: 0. Row 1 ties: 0.1. Row 2 is unlabelled. Row 3 leads by
    # 0.05 < 0.1: 0.05.
    assert float(margin_loss(q, labels, 0.1)) == pytest.approx((0.0 + 0.1 + 0.05) / 3)
    assert float(margin_loss(q, torch.full((4,), NO_LABEL), 0.1)) == 0.0


def test_only_a_planner_can_teach() -> None:
    with pytest.raises(LearningError, match="teacher: expected one of"):
        TrainConfig(teacher="random").validate()
    # The oracle's coverage count is the score of the paper's world only.
    for world in ({"sensor": "camera"}, {"comm": "range=500"}):
        with pytest.raises(LearningError, match="oracle plans on the paper's world only"):
            TrainConfig(teacher="oracle", **world).validate()  # type: ignore[arg-type]
    with pytest.raises(LearningError, match="teacher_margin > 0"):
        TrainConfig(teacher="rh", teacher_margin=0.0).validate()


@pytest.mark.parametrize("name", ["rh", BELIEF_PLANNER])
def test_a_label_is_the_action_the_planner_flies_when_it_plans(name: str) -> None:
    # One aircraft, so the planner draws its restarts from one generator: the teacher given
    # the same generator must plan the same sequence from the same state, map and weights.
    config = EnvConfig(n_aircraft=1, observation="obs", reward="obs").validate()
    env = WildfireVecEnv(config, 1)
    observations = env.reset(np.array([11]))
    planner = make_vec_policy(name)
    planner.reset(env)
    teacher = PlannerTeacher(name, generator(11, Stream.AIRCRAFT, 0))
    replans = 0
    for decision in range(25):
        due = bool(planner.planner.due()[0])  # type: ignore[attr-defined]
        label = teacher.labels(env, np.array([0])) if due else None
        action = planner.act(env, observations)
        if label is not None:
            assert label.tolist() == action.reshape(-1).tolist(), decision
            replans += 1
        observations = env.step(action).observations
    assert replans == 3  # decisions 0, 10 and 20


def test_an_oracle_label_is_the_action_the_oracle_flies_when_it_replans() -> None:
    # Flying the oracle's own flight, the teacher asked at the oracle's re-plans (decisions
    # 0, 10, 20) re-plans from the same poses, the same covered cells (the team's belief) and
    # the same warm start, with the same random streams: it must choose what the oracle flew.
    config = EnvConfig(n_aircraft=2).validate()
    oracle_config = OracleConfig(incumbents=())
    flight = plan_episode(known_future(11, config), oracle_config).actions
    env = WildfireVecEnv(config, 1)
    env.reset(np.array([11]))
    teacher = OracleTeacher(oracle_config)
    for decision in range(25):
        if decision == 20:  # the team has scored cells, which the teacher must count covered
            assert env.scores[0] > 0
        if decision % oracle_config.replan_every == 0:
            label = teacher.labels(env, np.array([0]))
            assert label.tolist() == flight[:, decision].tolist(), decision
        env.step(flight[None, :, decision])


def test_labels_travel_with_their_frames_and_survive_a_save(tmp_path: Path) -> None:
    replay = ReplayBuffer(10, (1, 2, 2), (1, 5), ImageCodec.for_approach("obs"))
    images = np.zeros((4, 1, 2, 2), np.float32)
    states = np.arange(20, dtype=np.float32).reshape(4, 1, 5)
    ids = replay.add_frames(images, states, labels=np.array([1, 0, 1, NO_LABEL], np.int8))
    replay.add_frames(images[:1], states[:1])  # a frame without a teacher
    replay.add_transitions(ids[:3], np.zeros(3), np.zeros(3), 0.0, ids[1:])
    batch = replay.sample(64, np.random.default_rng(0))
    by_state = {
        float(s[0, 0]): int(label) for s, label in zip(batch.states, batch.labels, strict=True)
    }
    assert by_state == {0.0: 1, 5.0: 0, 10.0: 1}
    replay.save(tmp_path / "replay.npz")
    loaded = ReplayBuffer.load(tmp_path / "replay.npz")
    assert loaded.labels[:5].tolist() == [1, 0, 1, NO_LABEL, NO_LABEL]


@pytest.mark.parametrize("name", ["rh", "oracle"])
def test_training_episodes_label_while_the_teacher_has_weight(name: str) -> None:
    config = TrainConfig(
        approach="obs", num_envs=2, teacher=name, teacher_iterations=5, episode_seconds=3.0
    ).validate()
    replay = new_replay(config, 500, [])
    state = TrainState()
    episodes = TrainingEpisodes(config, replay, state, np.random.default_rng(0))
    rng = np.random.default_rng(1)
    for _ in range(40):  # 3 s episodes: some end and restart on the way
        episodes.step(rng.integers(0, 2, (2, 2)), replay, state)
    written = replay.labels[: replay.frames_written]
    assert state.episodes > 2 and (written >= 0).mean() > 0.9
    state.iterations = 5  # the teacher's weight is 0 from here: no more labels
    before = replay.frames_written
    episodes.step(rng.integers(0, 2, (2, 2)), replay, state)
    assert (replay.labels[before : replay.frames_written] == NO_LABEL).all()


def test_the_margin_loss_teaches_the_labels() -> None:
    # Frames labelled by a rule the network can read (bank sign of the ownship's state),
    # rewards all zero: only the teacher's loss tells the actions apart.
    torch.manual_seed(0)
    rng = np.random.default_rng(0)
    config = TrainConfig(approach="obs", batch_size=32, teacher="rh").validate()
    replay = ReplayBuffer(2000, (1, 30, 40), (1, 5), ImageCodec.for_approach("obs"))
    states = rng.standard_normal((2001, 1, 5)).astype(np.float32)
    labels = (states[:, 0, 2] > 0).astype(np.int8)
    ids = replay.add_frames(np.zeros((2001, 1, 30, 40), np.float32), states, labels=labels)
    replay.add_transitions(ids[:-1], rng.integers(0, 2, 2000), np.zeros(2000), 0.0, ids[1:])
    q_network, target = (build_q_network("obs") for _ in range(2))
    target.load_state_dict(q_network.state_dict())
    optimizer = torch.optim.Adamax(q_network.parameters(), lr=3e-3)

    def agreement() -> float:
        with torch.no_grad():
            q = q_network(torch.zeros(2001, 1, 30, 40), torch.from_numpy(states)).sum(dim=1)
        return float((q.argmax(dim=1).numpy() == labels).mean())

    before = agreement()
    for _ in range(80):
        td_update(q_network, target, optimizer, replay, config, rng, teacher_weight=1.0)
    assert before < 0.7 and agreement() > 0.9
