"""The radio links of a batch of episodes: messages in flight, replicas, heard poses, catch-up.

:class:`TeamRadio` is what :class:`~wildfire_world.env.WildfireVecEnv` keeps under a
limited radio model (docs/model.md, Radio links), for every aircraft of every episode at
once. It calls the functions an agent's :class:`~wildfire_agent.aircraft_radio.AircraftRadio`
calls, in the same order within a tick, so a lockstep run decides exactly as the
environment:

1. compose the tick's messages: each aircraft's catch-up digests and replies, from its
   replica as it stands (``wildfire_belief.catch_up``);
2. merge every aircraft's own visit;
3. decide, from the positions now and the links' draws, who will hear each message (at
   ``t + delay``: messages wait in a ring of ``delay + 1`` slots);
4. hear the messages of ``t - delay``: their visits, poses, digests (answered next tick) and
   replies (merged now); a message that ends a gap asks for a catch-up next tick.

Visits and poses are arrays over the batch; catch-up exchanges are rare, and are handled one
by one.
"""

from __future__ import annotations

import numpy as np

from wildfire_agent.approaches import belief_images
from wildfire_agent.dynamics import AircraftState
from wildfire_agent.heard_poses import HeardPoses
from wildfire_belief.catch_up import CatchUpQueue, link_returned, reply_keys, retry_ticks
from wildfire_belief.radio import CommModel, LinkDraws, delivered
from wildfire_belief.replicas import BeliefReplicas, visit_key
from wildfire_belief.visits import VISIT_WINDOW, VisitWindows
from wildfire_msgs_py.radio_codec import Digest, Reply
from wildfire_sim.grid import PAPER_MAP, MapGeometry


class RadioLinks:
    """Radio links and heard poses of ``num_envs`` episodes of ``n`` aircraft: what every
    message carries but its payload (visits, :class:`TeamRadio`, or noisy reports,
    ``team_report_radio.TeamReportRadio``), which the subclass keeps and merges."""

    def __init__(
        self, model: CommModel, num_envs: int, n: int, geometry: MapGeometry = PAPER_MAP
    ) -> None:
        self.model = model
        self.n = n
        self.geometry = geometry
        self.heard = HeardPoses(num_envs, n, n)
        self.draws = LinkDraws(num_envs, n)
        slots, shape = model.delay + 1, (model.delay + 1, num_envs, n)
        self.sent_tick = np.full((slots, num_envs), -1, dtype=np.int64)
        self.pose = AircraftState(
            np.zeros(shape), np.zeros(shape), np.zeros(shape), np.zeros(shape, dtype=np.int64)
        )
        self.reaches = np.zeros((*shape, n), dtype=bool)
        """[slot, e, sender, receiver]: the message will be heard."""
        self.queues = [[self.new_queue() for _ in range(n)] for _ in range(num_envs)]
        self.sections: dict[tuple[int, int, int], tuple[tuple[Digest, ...], tuple[Reply, ...]]]
        self.sections = {}
        """Catch-up sections of the messages in flight, by (slot, episode, sender)."""

    def reset_links(self, env_ids: np.ndarray) -> None:
        self.sent_tick[:, env_ids] = -1
        for e in np.atleast_1d(env_ids).tolist():
            self.queues[e] = [self.new_queue() for _ in range(self.n)]

    def new_queue(self) -> CatchUpQueue:
        return CatchUpQueue(retry_ticks(self.model.delay))

    def exchange(
        self, envs: np.ndarray, tick: np.ndarray, seeds: np.ndarray, pose: AircraftState
    ) -> None:
        """Steps 1, 3 and 4 of the module notes for the ``envs`` (their payloads stored by
        the subclass in ring slot ``tick % (delay + 1)`` after :meth:`compose`)."""
        slots = self.model.delay + 1
        slot = tick[envs] % slots
        self.sent_tick[slot, envs] = tick[envs]
        for ring, now in zip(self.pose, pose, strict=True):
            ring[slot, envs] = now[envs]
        draws = self.draws.at(seeds, tick)[envs]
        reach = delivered(self.model, draws, pose.x_m[envs], pose.y_m[envs], tick[envs])
        self.reaches[slot, envs] = reach
        # Own payloads: receiver i is sender i, heard at once.
        own = np.zeros((len(envs), self.n, self.n), dtype=bool)
        own[:, np.arange(self.n), np.arange(self.n)] = True
        self.merge(envs, slot, own)
        # The messages of tick - delay (the same slot when there is no delay).
        sent = tick[envs] - self.model.delay
        old = sent % slots
        due = self.sent_tick[old, envs] == sent
        heard = self.reaches[old, envs] & due[:, None, None]
        self.merge(envs, old, heard)
        e, j, i = np.nonzero(heard)
        returned = link_returned(self.heard.tick[envs[e], i, j], sent[e])
        self.heard.hear(
            envs[e], i, j, sent[e], AircraftState(*(f[old[e], envs[e], j] for f in self.pose))
        )
        now = tick[envs]
        for k in range(len(e)):
            env, sender, receiver = int(envs[e[k]]), int(j[k]), int(i[k])
            self.queues[env][receiver].on_heard(sender, int(now[e[k]]), bool(returned[k]))
            self.hear_sections(int(old[e[k]]), env, sender, receiver)

    def compose(self, envs: np.ndarray, slot: np.ndarray, tick: np.ndarray) -> None:
        """Catch-up sections of this tick's messages, from the replicas as they stand."""
        for env, s, now in zip(envs.tolist(), slot.tolist(), tick.tolist(), strict=True):
            for i, queue in enumerate(self.queues[env]):
                self.sections.pop((s, env, i), None)
                if queue.asks or queue.answers:
                    self.sections[s, env, i] = self.sections_of(queue, now, env, i)

    def hear_sections(self, slot: int, env: int, sender: int, receiver: int) -> None:
        """A heard message's digests (answered next tick) and replies (merged now)."""
        digests, replies = self.sections.get((slot, env, sender), ((), ()))
        queue = self.queues[env][receiver]
        for digest in digests:
            if digest.target == receiver:
                queue.on_digest(sender, digest.block_ticks)
        for reply in replies:
            if reply.target == receiver:
                queue.on_reply(sender)
                self.merge_reply(env, receiver, reply)

    # The payload's side, in the subclass.
    def sections_of(
        self, queue: CatchUpQueue, tick: int, env: int, aircraft: int
    ) -> tuple[tuple[Digest, ...], tuple[Reply, ...]]:
        raise NotImplementedError

    def merge(self, envs: np.ndarray, slot: np.ndarray, heard: np.ndarray) -> None:
        """Merge the payloads of messages ``heard[e, sender, receiver]`` in ring ``slot[e]``."""
        raise NotImplementedError

    def merge_reply(self, env: int, receiver: int, reply: Reply) -> None:
        raise NotImplementedError


class TeamRadio(RadioLinks):
    """Radio links, binary replicas and heard poses of ``num_envs`` episodes of ``n``
    aircraft under the paper's perfect sensing: the messages carry visits."""

    def __init__(
        self, model: CommModel, num_envs: int, n: int, geometry: MapGeometry = PAPER_MAP
    ) -> None:
        super().__init__(model, num_envs, n, geometry)
        self.replicas = BeliefReplicas(num_envs, n, geometry)
        shape = (model.delay + 1, num_envs, n)
        self.row0 = np.zeros(shape, dtype=np.int64)
        self.col0 = np.zeros(shape, dtype=np.int64)
        window = (*shape, VISIT_WINDOW, VISIT_WINDOW)
        self.visited = np.zeros(window, dtype=bool)
        self.seen = np.zeros(window, dtype=bool)

    def reset(self, env_ids: np.ndarray, believed_burning: np.ndarray) -> None:
        self.replicas.reset(env_ids, believed_burning)
        self.reset_links(env_ids)

    def send(
        self,
        active: np.ndarray,
        tick: np.ndarray,
        seeds: np.ndarray,
        pose: AircraftState,
        windows: VisitWindows,
        seen: np.ndarray,
    ) -> None:
        """Every aircraft of the ``active`` episodes sends its tick-``tick`` message; merge
        its own visit and the messages heard at this tick into the replicas."""
        envs = np.flatnonzero(active)
        slot = tick[envs] % (self.model.delay + 1)
        self.compose(envs, slot, tick[envs])
        self.replicas.tick(envs)
        self.row0[slot, envs] = windows.row0[envs]
        self.col0[slot, envs] = windows.col0[envs]
        self.visited[slot, envs] = windows.visited[envs]
        self.seen[slot, envs] = seen[envs]
        self.exchange(envs, tick, seeds, pose)

    def sections_of(
        self, queue: CatchUpQueue, tick: int, env: int, aircraft: int
    ) -> tuple[tuple[Digest, ...], tuple[Reply, ...]]:
        return queue.compose(
            tick, self.replicas.key[env, aircraft], self.replicas.burning[env, aircraft]
        )

    def merge_reply(self, env: int, receiver: int, reply: Reply) -> None:
        count = reply.cells.size
        self.replicas.merge(
            np.full(count, env),
            np.full(count, receiver),
            reply.cells.astype(np.int64),
            reply_keys(reply),
            reply.burning,
        )

    def merge(self, envs: np.ndarray, slot: np.ndarray, heard: np.ndarray) -> None:
        e, j, i = np.nonzero(heard)
        s, env = slot[e], envs[e]
        m, a, b = np.nonzero(self.visited[s, env, j])
        source = (s[m], env[m], j[m])
        cell = (self.row0[source] + a) * self.geometry.cols + self.col0[source] + b
        key = visit_key(self.sent_tick[s[m], env[m]], j[m])
        self.replicas.merge(env[m], i[m], cell, key, self.seen[(*source, a, b)])

    def believed(self) -> np.ndarray:
        """What each aircraft believes burning, (E * N, H, W) bool."""
        return self.replicas.burning.reshape(-1, *self.geometry.shape)

    def belief_images(self, pose: AircraftState) -> np.ndarray:
        """Each aircraft's ego image of its own replica, (E, N, 2, 100, 100)."""
        replicas = self.replicas
        e, n = replicas.burning.shape[:2]
        flat = AircraftState(*(f.reshape(e * n, 1) for f in pose))
        images = belief_images(
            replicas.burning.reshape(e * n, *self.geometry.shape),
            replicas.age_s().reshape(e * n, *self.geometry.shape),
            flat,
        )
        return images.reshape(e, n, *images.shape[2:])


__all__ = ["RadioLinks", "TeamRadio"]
