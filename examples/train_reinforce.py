"""Train a policy of your own with a loop of your own: REINFORCE on the PettingZoo env.

CleanRL-style, in one file: hyperparameters in a dataclass parsed from the command line, one
explicit training loop over :class:`~wildfire_world.parallel_env.WildfireParallelEnv`
(the PettingZoo parallel API: one dict entry per aircraft), the aircraft sharing one small
policy network, each aircraft's discounted return weighting its own log-probabilities.

    python examples/train_reinforce.py --episodes 20 --out runs/reinforce_policy.pt
    REINFORCE_POLICY=runs/reinforce_policy.pt \\
        wildfire eval --policy examples/train_reinforce.py:ReinforcePolicy

:class:`ReinforcePolicy` is the trained network as a vector policy (docs/policies.md), so
``wildfire eval``, ``report`` and ``run`` fly it like any other.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from wildfire_world.env import EnvConfig
from wildfire_world.parallel_env import WildfireParallelEnv


@dataclass
class Args:
    """Hyperparameters (each one a command-line flag)."""

    seed: int = 1
    """Seed of the first episode (episode i flies seed + i) and of torch."""
    episodes: int = 50
    """Training episodes."""
    episode_seconds: float = 60.0
    """Flight time of a training episode, s (the fire may end it sooner)."""
    learning_rate: float = 1e-3
    """Adam's step size."""
    gamma: float = 0.99
    """Discount of the returns."""
    out: Path = Path("runs/reinforce_policy.pt")
    """Where the trained network's weights go."""


class PolicyNetwork(nn.Module):
    """Logits of the two actions from the belief image, pooled to 10 x 10, and the pairwise
    states."""

    def __init__(self, pairs: int) -> None:
        super().__init__()
        self.pool = nn.AvgPool2d(10)
        self.body = nn.Sequential(nn.Linear(2 * 10 * 10 + pairs * 5, 64), nn.ReLU())
        self.head = nn.Linear(64, 2)

    def forward(self, image: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        features = torch.cat([self.pool(image).flatten(1), state.flatten(1)], dim=1)
        return self.head(self.body(features))


def train(args: Args) -> PolicyNetwork:
    """The training loop; returns the trained network (also saved to ``args.out``)."""
    torch.manual_seed(args.seed)
    config = EnvConfig(observation="belief", max_duration_s=args.episode_seconds)
    env = WildfireParallelEnv(config)
    network = PolicyNetwork(max(config.n_aircraft - 1, 1))
    optimizer = torch.optim.Adam(network.parameters(), lr=args.learning_rate)
    start = time.monotonic()
    for episode in range(args.episodes):
        observations, _ = env.reset(seed=args.seed + episode)
        log_probs: dict[str, list[torch.Tensor]] = {agent: [] for agent in env.agents}
        rewards: dict[str, list[float]] = {agent: [] for agent in env.agents}
        while env.agents:
            actions = {}
            for agent, observation in observations.items():
                logits = network(
                    torch.from_numpy(observation["image"])[None],
                    torch.from_numpy(observation["state"])[None],
                )
                distribution = torch.distributions.Categorical(logits=logits[0])
                action = distribution.sample()
                log_probs[agent].append(distribution.log_prob(action))
                actions[agent] = int(action)
            observations, reward, _, _, _ = env.step(actions)
            for agent, value in reward.items():
                rewards[agent].append(value)
        loss = torch.zeros(())
        for agent, agent_rewards in rewards.items():
            returns = discounted(np.asarray(agent_rewards), args.gamma)
            returns = (returns - returns.mean()) / (returns.std() + 1e-8)  # a baseline, scaled
            loss = loss - (torch.stack(log_probs[agent]) * torch.from_numpy(returns)).sum()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        print(f"episode {episode}: score {env.score}, {time.monotonic() - start:.1f} s")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    torch.save(network.state_dict(), args.out)
    return network


def discounted(rewards: np.ndarray, gamma: float) -> np.ndarray:
    """The return from each decision on, float32."""
    returns = np.zeros(len(rewards), dtype=np.float32)
    running = 0.0
    for t in range(len(rewards) - 1, -1, -1):
        running = rewards[t] + gamma * running
        returns[t] = running
    return returns


class ReinforcePolicy:
    """The trained network, greedy, as a vector policy (weights: ``$REINFORCE_POLICY``)."""

    observation = "belief"

    def __init__(self) -> None:
        self.path = Path(os.environ.get("REINFORCE_POLICY", "runs/reinforce_policy.pt"))
        self.network: PolicyNetwork | None = None

    def reset(self, env: Any) -> None:
        pairs = max(env.aircraft.x_m.shape[1] - 1, 1)
        if self.network is None:
            self.network = PolicyNetwork(pairs)
            self.network.load_state_dict(torch.load(self.path, weights_only=True))

    @torch.no_grad()
    def act(self, env: Any, observations: dict[str, np.ndarray]) -> np.ndarray:
        assert self.network is not None, "reset() first"
        images, states = observations["image"], observations["state"]
        actions = np.zeros(images.shape[:2], dtype=np.int64)
        # One aircraft at a time: a larger batch may change the last bits of a logit, and an
        # agent node evaluates its aircraft alone.
        for e, k in np.ndindex(*actions.shape):
            image = torch.from_numpy(images[e, k : k + 1])
            logits = self.network(image, torch.from_numpy(states[e, k : k + 1]))
            actions[e, k] = int(logits[0].argmax())
        return actions


def parse_args() -> Args:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    for field in dataclasses.fields(Args):
        flag, default = f"--{field.name.replace('_', '-')}", field.default
        parser.add_argument(flag, type=type(default), default=default)
    return Args(**vars(parser.parse_args()))


if __name__ == "__main__":
    train(parse_args())
