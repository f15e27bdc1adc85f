"""The radio links of a batch of episodes under noisy sensing: the messages carry reports.

With noisy sensing (``--sensor camera``, or a pixel error) under a limited radio model each
aircraft keeps its own filtered belief (``wildfire_belief.filtered_replicas``), fused from
its own reports and every report it heard (docs/model.md, Noisy sensing under limited radio
links). :class:`TeamReportRadio` is the environment's side for every aircraft at once, on
the same links as :class:`~wildfire_world.team_radio.TeamRadio` (who hears which message,
when, the heard poses, the catch-up exchanges); only the payload differs:

* a message of tick ``t`` carries the sender's reports of ``t``: its sensor windows follow
  from its pose, so the wire needs only the bits (one per reading, in the windows' order);
* a catch-up digest says, per sender, the oldest tick of the replica's window it lacks a
  report of; the reply carries every report the peer holds from there on (its own and those
  it relayed), as ``(cell, tick, sender, value)`` readings;
* every replica settles once per tick, after its own reports, the messages heard and the
  replies: reports of older ticks (a delay, a reply) make it replay from a checkpoint.

The score stays the team's filtered belief of every report (``team_sensing``).
"""

from __future__ import annotations

import numpy as np

from wildfire_agent.approaches import belief_images
from wildfire_agent.dynamics import AircraftState
from wildfire_belief.catch_up import CatchUpQueue
from wildfire_belief.filtered_replicas import FilteredReplicas, replay_window
from wildfire_belief.radio import CommModel
from wildfire_msgs_py.belief_codec import published_probability
from wildfire_msgs_py.radio_codec import Digest, Reply
from wildfire_sim.grid import PAPER_MAP, MapGeometry
from wildfire_world.team_radio import RadioLinks

Reports = dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]
"""One decision's reports: (cells, values) of every (episode, aircraft) that sensed."""


class TeamReportRadio(RadioLinks):
    """Radio links, filtered replicas and heard poses of ``num_envs`` episodes of ``n``
    aircraft whose sensors report with flip probability ``p``."""

    def __init__(
        self,
        model: CommModel,
        num_envs: int,
        n: int,
        p: float,
        preburn_steps: int,
        geometry: MapGeometry = PAPER_MAP,
    ) -> None:
        super().__init__(model, num_envs, n, geometry)
        self.replicas = FilteredReplicas(num_envs, n, p, geometry, replay_window(model))
        self.preburn_steps = preburn_steps
        self._probability = np.zeros((num_envs * n, *geometry.shape))
        self._sent: Reports = {}
        """The reports of the tick being sent (each aircraft holds its own at once)."""

    def reset(self, env_ids: np.ndarray, ignition: np.ndarray, fuel: np.ndarray) -> None:
        """Start over: every replica from the team's start belief (as ``TeamSensing``)."""
        self.replicas.reset(env_ids, ignition, fuel, self.preburn_steps)
        self.reset_links(env_ids)

    def send(
        self,
        active: np.ndarray,
        tick: np.ndarray,
        seeds: np.ndarray,
        pose: AircraftState,
        reports: Reports,
        fire_stepped: np.ndarray,
    ) -> None:
        """Every aircraft of the ``active`` episodes sends its tick-``tick`` reports; every
        replica holds its own and those it hears now, then settles."""
        envs = np.flatnonzero(active)
        slot = tick[envs] % (self.model.delay + 1)
        self.compose(envs, slot, tick[envs])
        self.replicas.tick(envs, fire_stepped[envs])
        self._sent = reports
        self.exchange(envs, tick, seeds, pose)
        self.replicas.settle()

    def merge(self, envs: np.ndarray, slot: np.ndarray, heard: np.ndarray) -> None:
        e, j, i = np.nonzero(heard)
        for env, sent, sender, receiver in zip(
            envs[e].tolist(),
            self.sent_tick[slot[e], envs[e]].tolist(),
            j.tolist(),
            i.tolist(),
            strict=True,
        ):
            # The sender's replica held its own report at once, so the log has it unless it
            # is older than the window (a delay longer than any replay).
            report = self.replicas.log[env].get((sent, sender))
            if report is None and sender == receiver:
                report = self._sent.get((env, sender))
            if report is not None:
                self.replicas.hold(env, receiver, sender, sent, *report)

    def sections_of(
        self, queue: CatchUpQueue, tick: int, env: int, aircraft: int
    ) -> tuple[tuple[Digest, ...], tuple[Reply, ...]]:
        replicas = self.replicas
        return queue.compose_with(
            tick,
            lambda _peer: replicas.digest(env, aircraft),
            lambda peer, digest: replicas.reply(env, aircraft, peer, digest),
        )

    def merge_reply(self, env: int, receiver: int, reply: Reply) -> None:
        self.replicas.hold_reply(env, receiver, reply)

    def believed(self) -> np.ndarray:
        """What each aircraft believes burning, (E * N, H, W) bool."""
        return self.replicas.belief.believed()

    def belief_images(self, pose: AircraftState) -> np.ndarray:
        """Each aircraft's ego image of its own filtered replica, (E, N, 2, 100, 100), in the
        whole percent an agent's network sees (as ``TeamSensing.probability``)."""
        belief = self.replicas.belief
        probability = belief.probability(out=self._probability)
        shown = published_probability(belief.believed(), probability)
        e, n = pose.x_m.shape
        flat = AircraftState(*(f.reshape(e * n, 1) for f in pose))
        images = belief_images(shown, belief.age_window, flat)
        return images.reshape(e, n, *images.shape[2:])


__all__ = ["Reports", "TeamReportRadio"]
