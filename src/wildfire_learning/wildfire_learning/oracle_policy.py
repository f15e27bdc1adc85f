"""The oracle as a vector policy: each episode planned whole when it starts, then replayed.

The planner is :mod:`wildfire_learning.oracle`; this is what ``wildfire eval`` and
``wildfire report`` fly under the name ``oracle``, with the planning time kept per seed
so that an evaluation counts it as the policy's work.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from wildfire_learning.oracle import (
    OracleConfig,
    OraclePlan,
    as_plan,
    known_future,
    plan_episode,
    refine,
)
from wildfire_learning.oracle_incumbents import flight_of
from wildfire_world.env import EnvConfig, VecPolicy, WildfireVecEnv


class OracleVecPolicy:
    """The oracle flying every aircraft of every episode of a vector environment: each
    episode is planned whole when it starts (its future is known), then replayed.

    The plan is the best of the search's own flight and the flights of the incumbent
    policies (``config.incumbents``, built by ``incumbent``: ``vec_policies.make_vec_policy``),
    refined by whole-episode best response (:func:`refine`)."""

    observation = "none"

    def __init__(
        self,
        config: OracleConfig | None = None,
        incumbent: Callable[[str], VecPolicy] | None = None,
    ) -> None:
        self.config = config or OracleConfig()
        if self.config.incumbents and incumbent is None:
            raise ValueError("OracleVecPolicy: incumbents named but no policy factory given")
        self.incumbent = incumbent
        self._incumbent_policies: dict[str, VecPolicy] = {}
        self.plans: dict[int, OraclePlan] = {}
        self.plan_seconds: dict[int, float] = {}
        """Wall time of each episode's planning (in ``reset``, which ``evaluate`` counts as
        the policy's ``planning_s``), by seed."""
        self.candidates: dict[int, dict[str, int]] = {}
        """Per seed, the score of each flight considered: the search's own (``search``), each
        incumbent's, and the refined plan (``refined``)."""

    def plan(self, seed: int, config: EnvConfig) -> OraclePlan:
        """The oracle's flight of episode ``seed`` (see the class docstring)."""
        tic = time.perf_counter()
        future = known_future(seed, config)
        found = {"search": plan_episode(future, self.config)}
        for name in self.config.incumbents:
            if name not in self._incumbent_policies:
                assert self.incumbent is not None
                self._incumbent_policies[name] = self.incumbent(name)
            found[name] = as_plan(future, flight_of(self._incumbent_policies[name], config, seed))
        scores = {name: plan.score for name, plan in found.items()}
        # Refine every flight found, the best first (the budget may not reach the last).
        deadline = tic + self.config.time_budget_s
        best = max(found.values(), key=lambda plan: plan.score)
        for plan in sorted(found.values(), key=lambda plan: -plan.score):
            refined = refine(future, plan, self.config, deadline)
            if refined.score > best.score:
                best = refined
        scores["refined"] = best.score
        self.candidates[seed] = scores
        self.plan_seconds[seed] = time.perf_counter() - tic
        return best

    def _plan_of(self, env: WildfireVecEnv, e: int) -> OraclePlan:
        """The plan of environment ``e``'s episode, planned the first time its seed is seen."""
        seed = int(env.seeds[e])
        if seed not in self.plans:
            self.plans[seed] = self.plan(seed, env.config)
        return self.plans[seed]

    def reset(self, env: WildfireVecEnv) -> None:
        for e in np.flatnonzero(~env.done).tolist():
            self._plan_of(env, e)

    def act(self, env: WildfireVecEnv, observations: dict[str, np.ndarray]) -> np.ndarray:
        actions = np.zeros((env.num_envs, env.config.n_aircraft), np.int64)
        for e in np.flatnonzero(~env.done).tolist():
            plan = self._plan_of(env, e)
            decision = int(env.decisions[e])
            if decision < plan.actions.shape[1]:
                actions[e] = plan.actions[:, decision]
        return actions


__all__ = ["OracleVecPolicy"]
