"""Bring your own policy: the vector-policy protocol, and ``--policy MODULE:ATTR``.

Every policy that flies the batched environment is a *vector policy* (:class:`VecPolicy`),
the shipped ones (``wildfire_learning.vec_policies``) and one written outside the project
alike. ``--policy MODULE:ATTR`` in ``wildfire eval``, ``wildfire report`` and ``wildfire
run`` (and an agent node's ``policy`` parameter) names one: ``MODULE`` is an importable
module (``my_pkg.policies``, the working directory first on the path, as ``python -m``
has it) or a ``.py`` file; ``ATTR`` is a class or a factory, called with no arguments, that
returns the policy. :func:`load_user_policy` is the one place that resolves it.

The protocol:

* ``observation``: ``"obs"``, ``"belief"`` or ``"none"``: what the environment renders;
* ``reset(env)``: called after each reset of ``env`` (a new batch of episodes);
* ``act(env, observations)``: the actions, (E, N) int64: 0 banks 5 degrees more to the right
  (-5 deg), 1 more to the left (+5 deg).

``observations`` holds ``"state"``, (E, N, K, 5) float32, each aircraft's normalised
pairwise states with its K other aircraft, and unless ``observation`` is ``"none"`` an
``"image"``, (E, N, C, H, W) float32: the sensor image (1 x 30 x 40; under camera sensing
the four camera images, 4 x 30 x 20) or the belief image (2 x 100 x 100, the aircraft at
pixel (50, 50), rows forward, columns to its right; channels probability of burning and
age / 255). Of ``env``, a policy reads only :class:`PolicyEnv`: ``num_envs``, ``seeds``,
``aircraft`` and ``done``.

The policy is decentralised: the action of aircraft ``k`` in episode ``e`` depends only on
row ``[e, k]`` of each observation, on its own pose ``env.aircraft[e, k]``, on
``env.seeds[e]`` and on what the policy kept of that aircraft's earlier calls; randomness
comes from one generator per aircraft, ``generator(seed, Stream.AIRCRAFT, k)``
(``wildfire_sim.seeding``). That is what lets an agent node fly it for its one aircraft
(:class:`OneAircraftEnv`): a lockstep run then flies exactly what ``wildfire eval`` flies.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path
from typing import Any, NamedTuple, Protocol

import numpy as np

from wildfire_agent.dynamics import AircraftState
from wildfire_agent.errors import AgentConfigError

USER_POLICY_FORM = "MODULE:ATTR"
"""How an error message names a policy from outside the project."""
OBSERVATIONS = ("obs", "belief", "none")
"""What a vector policy's ``observation`` may be."""


class PolicyEnv(Protocol):
    """What a vector policy reads of the environment it flies (see the module docstring)."""

    @property
    def num_envs(self) -> int:
        """E, the episodes flown at once."""

    @property
    def seeds(self) -> np.ndarray:
        """(E,) int64: each episode's seed."""

    @property
    def aircraft(self) -> AircraftState:
        """The poses, fields (E, N): x, y (m), heading (rad), bank in 5 degree steps."""

    @property
    def done(self) -> np.ndarray:
        """(E,) bool: episodes that have ended (their actions are ignored)."""


class VecPolicy(Protocol):
    """A vector policy: chooses the actions of every aircraft of every episode of an
    environment (see the module docstring; the shipped ones are in
    ``wildfire_learning.vec_policies`` and read all of ``WildfireVecEnv``)."""

    observation: str
    """What the environment must render for it: ``obs``, ``belief`` or ``none``."""

    def reset(self, env: Any) -> None:
        """Called after ``env.reset``: (re)seed per-aircraft randomness and plans."""

    def act(self, env: Any, observations: dict[str, np.ndarray]) -> np.ndarray:
        """Actions (E, N) int64."""


class OneAircraftEnv(NamedTuple):
    """The environment as an agent node gives it to a vector policy: one episode, the team
    as the aircraft knows it (:class:`PolicyEnv`)."""

    seeds: np.ndarray
    aircraft: AircraftState
    done: np.ndarray
    num_envs: int = 1

    @classmethod
    def of(cls, seed: int, team: AircraftState) -> OneAircraftEnv:
        """Episode ``seed`` with the team's poses ``team``, fields (1, n)."""
        return cls(np.array([seed], dtype=np.int64), team, np.zeros(1, dtype=bool))


def is_user_policy(name: str) -> bool:
    """True when ``name`` has the ``MODULE:ATTR`` form."""
    module, _, attr = name.rpartition(":")
    return bool(module) and attr.isidentifier()


def import_module(module: str, name: str) -> Any:
    """The module ``module`` (a dotted name or a ``.py`` path) of policy ``name``."""
    try:
        if module.endswith(".py"):
            path = Path(module).resolve()
            if not path.is_file():
                raise AgentConfigError(f"policy {name!r}: no file {module}")
            spec = importlib.util.spec_from_file_location(f"wildfire_user_{path.stem}", path)
            assert spec is not None and spec.loader is not None
            loaded = importlib.util.module_from_spec(spec)
            sys.modules[spec.name] = loaded  # dataclasses and pickling look modules up there
            spec.loader.exec_module(loaded)
            return loaded
        if "" not in sys.path:
            sys.path.insert(0, "")  # the working directory, as `python -m` has it
        return importlib.import_module(module)
    except AgentConfigError:
        raise
    except Exception as error:  # the user's module may raise anything while it loads
        raise AgentConfigError(
            f"policy {name!r}: cannot import {module} ({type(error).__name__}: {error})"
        ) from None


def load_user_policy(name: str) -> VecPolicy:
    """The vector policy that ``MODULE:ATTR`` builds; one-line :class:`AgentConfigError` for
    a module that fails to import, a missing attribute or an object without the protocol."""
    module_name, _, attr = name.rpartition(":")
    module = import_module(module_name, name)
    factory = getattr(module, attr, None)
    if factory is None:
        raise AgentConfigError(f"policy {name!r}: {module_name} has no attribute {attr!r}")
    if not callable(factory):
        raise AgentConfigError(f"policy {name!r}: {attr} is not a class or factory")
    try:
        policy = factory()
    except Exception as error:  # the user's constructor may raise anything
        raise AgentConfigError(
            f"policy {name!r}: {attr}() failed ({type(error).__name__}: {error})"
        ) from None
    missing = [m for m in ("reset", "act") if not callable(getattr(policy, m, None))]
    if missing:
        raise AgentConfigError(
            f"policy {name!r}: {attr}() has no {' or '.join(missing)} method "
            "(expected observation, reset(env) and act(env, observations))"
        )
    observation = getattr(policy, "observation", None)
    if observation not in OBSERVATIONS:
        raise AgentConfigError(
            f"policy {name!r}: observation {observation!r}: expected one of "
            f"{', '.join(OBSERVATIONS)}"
        )
    return policy  # protocol checked just above


def module_file(name: str) -> Path | None:
    """The source file of policy ``name``'s module (what its results depend on), if any."""
    module_name = name.rpartition(":")[0]
    if module_name.endswith(".py"):
        return Path(module_name).resolve()
    source = getattr(import_module(module_name, name), "__file__", None)
    return None if source is None else Path(source)


def checked_actions(actions: Any, shape: tuple[int, int], name: str) -> np.ndarray:
    """``actions`` as (E, N) int64 of 0 and 1; a clear error for anything else."""
    array = np.asarray(actions)
    if array.shape != shape or not np.isin(array, (0, 1)).all():
        raise AgentConfigError(
            f"policy {name!r}: act returned {array.dtype} {array.shape}: expected {shape} "
            "actions of 0 or 1"
        )
    return array.astype(np.int64)


__all__ = [
    "OBSERVATIONS",
    "USER_POLICY_FORM",
    "OneAircraftEnv",
    "PolicyEnv",
    "VecPolicy",
    "checked_actions",
    "import_module",
    "is_user_policy",
    "load_user_policy",
    "module_file",
]
