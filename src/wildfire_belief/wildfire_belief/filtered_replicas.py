"""Filtered belief replicas: every aircraft's own filtered belief under limited radio links.

See docs/model.md, Noisy sensing under limited radio links. With noisy sensing each aircraft
keeps a :class:`~wildfire_belief.filtered_belief.LogOddsBelief` of its own, fused from its
own reports and every report it heard. A *report* is one reading of one cell, keyed by its
tick and its sender; every report of the key ``(tick, sender)`` travels together (one radio
message, or a catch-up reply).

The filter is not commutative: the log-odds are clipped once per tick, and the process term
moves the belief at every fire step. So a replica is defined as the filter run **in tick
order** over the reports it holds, whatever the order they arrived in:

* each replica keeps the reports of the last ``window_ticks`` ticks (:attr:`log`) and a
  *checkpoint* of its filter state after the process step of every fire step in that window;
* :meth:`FilteredReplicas.settle` applies what arrived since the last call. Reports of the
  current tick only: one update (the usual case, and the only one with perfect links, where
  every replica then equals the team's filtered belief bit for bit). A report of an older
  tick (a delayed message, a catch-up reply) is *late*: the replica returns to the checkpoint
  of the fire step before it and re-runs the filter from there, every fire step and every
  tick's reports, up to now;
* the same report held twice counts once; a report older than the oldest checkpoint cannot
  be replayed and is dropped (counted in :attr:`too_old`).

Two replicas that hold the same reports of the window and agreed at its start are therefore
equal bit for bit, in whatever order and however often the reports came.

Arrays are those of one :class:`LogOddsBelief` over ``num_envs * replicas`` beliefs: replica
``r`` of environment ``e`` is belief ``e * replicas + r``.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from wildfire_belief.catch_up import DIGEST_TICK_CAP
from wildfire_belief.filtered_belief import LogOddsBelief
from wildfire_belief.radio import CommModel
from wildfire_belief.replicas import KEY_AIRCRAFT
from wildfire_msgs_py.radio_codec import DIGEST_BLOCKS, Reply
from wildfire_sim.episode import DECISIONS_PER_FIRE_STEP
from wildfire_sim.grid import PAPER_MAP, MapGeometry

REPLAY_TICKS = 300
"""Ticks of reports a replica keeps and can replay (30 s): a report that arrives later than
that after its tick is dropped. It bounds the longest partition after which the replicas
still become equal (docs/model.md)."""


def replay_window(model: CommModel) -> int:
    """Ticks a replica keeps and replays under ``model``: :data:`REPLAY_TICKS`, or the
    model's delay and two fire steps when longer."""
    return max(REPLAY_TICKS, model.delay + 2 * DECISIONS_PER_FIRE_STEP)


def fire_step_at(tick: int) -> bool:
    """Whether the fire (and so the filter's process term) steps at ``tick``."""
    return tick > 0 and tick % DECISIONS_PER_FIRE_STEP == 0


class FilteredReplicas:
    """``replicas`` filtered replicas in each of ``num_envs`` environments (module notes)."""

    def __init__(
        self,
        num_envs: int,
        replicas: int,
        p: float,
        geometry: MapGeometry = PAPER_MAP,
        window_ticks: int = REPLAY_TICKS,
        senders: int | None = None,
    ) -> None:
        self.replicas = replicas
        self.senders = replicas if senders is None else senders
        """Aircraft whose reports a replica may hold (the team: one replica per aircraft in
        the environment, one in an agent node)."""
        self.belief = LogOddsBelief(num_envs * replicas, p, geometry=geometry)
        self.geometry = geometry
        self.slots = window_ticks // DECISIONS_PER_FIRE_STEP + 1
        shape = (self.slots, num_envs * replicas, *geometry.shape)
        self._saved = tuple(np.zeros(shape) for _ in range(3))
        """Checkpoints of (log_odds, spent, burn_age) by fire step, a ring of ``slots``."""
        self._saved_tick = np.full((self.slots, num_envs * replicas), -1, dtype=np.int64)
        self.log: list[dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]]
        self.log = [{} for _ in range(num_envs)]
        """Per environment, the reports ``(cells, values)`` of each key ``(tick, sender)``
        any of its replicas holds (a report is the same wherever it is held)."""
        self.held: list[dict[int, set[int]]] = [
            defaultdict(set) for _ in range(num_envs * replicas)
        ]
        """Per replica, the senders of the reports it holds, by tick."""
        self._fresh = np.full(num_envs * replicas, -1, dtype=np.int64)
        """Per replica, the oldest tick of the reports held since the last settle (-1: none)."""
        self._applied = np.zeros(num_envs * replicas, dtype=np.int64)
        """Per replica, the tick whose reports its filter state includes."""
        self.too_old = np.zeros(num_envs * replicas, dtype=np.int64)
        """Per replica, reports that came too late to be replayed (dropped)."""

    # ---------------------------------------------------------------- indices
    def ids(self, env_ids: np.ndarray | list[int]) -> np.ndarray:
        """The belief indices of every replica of ``env_ids``."""
        env_ids = np.atleast_1d(np.asarray(env_ids, dtype=np.int64))
        return (env_ids[:, None] * self.replicas + np.arange(self.replicas)).reshape(-1)

    @property
    def now(self) -> np.ndarray:
        return self.belief.now

    # ------------------------------------------------------------------ clock
    def reset(
        self,
        env_ids: np.ndarray | list[int],
        ignition: np.ndarray,
        fuel_mask: np.ndarray,
        preburn_steps: int,
    ) -> None:
        """Start over: every replica of ``env_ids`` from the team's start belief (k, H, W)."""
        env_ids = np.atleast_1d(np.asarray(env_ids, dtype=np.int64))
        ids = self.ids(env_ids)
        repeat = self.replicas
        self.belief.reset(
            ids,
            np.repeat(np.asarray(ignition, bool), repeat, axis=0),
            np.repeat(np.asarray(fuel_mask, bool), repeat, axis=0),
            preburn_steps,
        )
        for e in env_ids.tolist():
            self.log[e] = {}
        for r in ids.tolist():
            self.held[r] = defaultdict(set)
        self._fresh[ids] = -1
        self._applied[ids] = 0
        self.too_old[ids] = 0
        self._saved_tick[:, ids] = -1
        self._checkpoint(ids, 0)

    def tick(self, env_ids: np.ndarray, fire_stepped: np.ndarray) -> None:
        """One decision of ``env_ids``; the process term of those whose fire stepped."""
        self.settle()  # what is held belongs to the ticks before this one
        ids = self.ids(env_ids)
        self.belief.tick(ids)
        stepped = self.ids(np.asarray(env_ids)[np.asarray(fire_stepped, bool)])
        if stepped.size:
            self.belief.predict(stepped)
            # Episodes restart on their own, so the clocks of a batch differ.
            for tick in np.unique(self.now[stepped]).tolist():
                self._checkpoint(stepped[self.now[stepped] == tick], tick)

    # ---------------------------------------------------------------- reports
    def hold(
        self, env: int, replica: int, sender: int, tick: int, cells: np.ndarray, values: np.ndarray
    ) -> bool:
        """Replica ``replica`` of ``env`` now holds ``sender``'s reports of ``tick``: flat
        cells and reported values. Returns whether they are new to it (applied at the next
        :meth:`settle`); a report held already, too old to replay, or of a tick the
        replica has not reached (callers hear a message once its tick is flown), changes
        nothing."""
        r = env * self.replicas + replica
        if sender in self.held[r].get(tick, ()) or tick > self.now[r]:
            return False
        if tick < self.window_start(r):
            self.too_old[r] += 1
            return False
        self.log[env].setdefault((tick, sender), (cells, values))
        self.held[r][tick].add(sender)
        self._fresh[r] = tick if self._fresh[r] < 0 else min(self._fresh[r], tick)
        return True

    def holds(self, env: int, replica: int, sender: int, tick: int) -> bool:
        return sender in self.held[env * self.replicas + replica].get(tick, ())

    def window_start(self, r: int) -> int:
        """The oldest tick replica ``r`` can still replay from (its oldest checkpoint)."""
        kept = self._saved_tick[:, r]
        return int(kept[kept >= 0].min())

    def settle(self) -> None:
        """Apply every report held since the last call (module notes)."""
        now = self.now
        fresh = self._fresh >= 0
        current = fresh & (self._fresh == now) & (self._applied < now)
        late = fresh & ~current
        if current.any():
            self._update(np.flatnonzero(current), now)
        self._applied[...] = now
        late_ids = np.flatnonzero(late)
        if late_ids.size:
            self._replay(late_ids)
        self._fresh[fresh] = -1

    def _update(self, ids: np.ndarray, ticks: np.ndarray) -> None:
        """One batched update of every report each of ``ids`` holds of ``ticks[id]``."""
        envs, cells, values = [], [], []
        for r in ids.tolist():
            t, log = int(ticks[r]), self.log[r // self.replicas]
            for sender in sorted(self.held[r].get(t, ())):
                report = log[t, sender]
                envs.append(np.full(report[0].size, r, dtype=np.int64))
                cells.append(report[0])
                values.append(report[1])
        if envs:
            self.belief.update(np.concatenate(envs), np.concatenate(cells), np.concatenate(values))

    def _replay(self, ids: np.ndarray) -> None:
        """Re-run the filter of ``ids`` from the checkpoint before each one's oldest fresh
        report (grouped by checkpoint, batched within a group) up to now."""
        step = DECISIONS_PER_FIRE_STEP
        starts = self._fresh[ids] // step * step
        now = self.now[ids].copy()
        for start in np.unique(starts).tolist():
            group = ids[starts == start]
            self._restore(group, start)
            last = int(now[starts == start].max())
            ticks = np.zeros_like(self.now)
            for tick in range(start, last + 1):
                moving = group[now[starts == start] >= tick]
                if tick > start and fire_step_at(tick):
                    self.belief.predict(moving)
                    self._checkpoint(moving, tick)
                ticks[moving] = tick
                self.belief.now[moving] = tick
                self._update(moving, ticks)
        self.belief.now[ids] = now

    # ------------------------------------------------------------- checkpoints
    def _checkpoint(self, ids: np.ndarray, tick: int) -> None:
        slot = (tick // DECISIONS_PER_FIRE_STEP) % self.slots
        belief = self.belief
        for saved, state in zip(
            self._saved, (belief.log_odds, belief.spent, belief.burn_age), strict=True
        ):
            saved[slot, ids] = state[ids]
        self._saved_tick[slot, ids] = tick
        # Reports older than the oldest checkpoint left can never be replayed: forget them.
        oldest = tick - (self.slots - 1) * DECISIONS_PER_FIRE_STEP
        for r in ids.tolist():
            for old in [t for t in self.held[r] if t < oldest]:
                del self.held[r][old]
        for e in np.unique(ids // self.replicas).tolist():
            log = self.log[e]
            for key in [k for k in log if k[0] < oldest]:
                del log[key]

    def _restore(self, ids: np.ndarray, tick: int) -> None:
        slot = (tick // DECISIONS_PER_FIRE_STEP) % self.slots
        if np.any(self._saved_tick[slot, ids] != tick):
            raise RuntimeError(f"filtered replicas: no checkpoint of tick {tick} to replay from")
        belief = self.belief
        for saved, state in zip(
            self._saved, (belief.log_odds, belief.spent, belief.burn_age), strict=True
        ):
            state[ids] = saved[slot, ids]

    # --------------------------------------------------------------- catch-up
    def digest(self, env: int, replica: int) -> np.ndarray:
        """A catch-up digest of the replica's reports, (100,) uint16.

        Entry ``s`` of the first ``n`` (one per sender): the oldest tick of the window whose
        report of ``s`` the replica lacks (the 16-bit cap when later: that only lengthens
        the reply). The other entries are a bitmask, ``mask_bits`` per sender: which of the
        ticks from there on it holds, so that the reply skips them (under loss, the oldest
        missing tick is often far back, and most after it are held).
        """
        n, width = self.senders, self.mask_bits
        r = env * self.replicas + replica
        block_ticks = np.full(DIGEST_BLOCKS, DIGEST_TICK_CAP, dtype=np.uint16)
        mask = np.zeros((n, width), dtype=bool)
        for sender in range(n):
            since = min(self.first_missing(env, replica, sender), DIGEST_TICK_CAP)
            block_ticks[sender] = since
            for bit in range(width):
                mask[sender, bit] = sender in self.held[r].get(since + bit, ())
        words = np.packbits(mask.reshape(-1)).tobytes().ljust(2 * (DIGEST_BLOCKS - n), b"\0")
        block_ticks[n:] = np.frombuffer(words, dtype="<u2")
        return block_ticks

    @property
    def mask_bits(self) -> int:
        """Ticks per sender a digest's bitmask covers (the 16-bit words after the first n)."""
        return (DIGEST_BLOCKS - self.senders) * 16 // self.senders

    def reply(self, env: int, replica: int, target: int, block_ticks: np.ndarray) -> Reply:
        """The answer to ``target``'s digest: every report the replica holds that the digest
        does not say ``target`` holds, but for ``target``'s own, one entry per reading."""
        n, width = self.senders, self.mask_bits
        block_ticks = np.asarray(block_ticks, dtype=np.uint16)
        since = block_ticks[:n].astype(np.int64)
        words = block_ticks[n:].astype("<u2").tobytes()
        held = np.unpackbits(np.frombuffer(words, np.uint8))[: n * width].reshape(n, width)
        found = [
            report
            for report in self.reports_since(env, replica, since, target)
            if not (
                report[0] - since[report[1]] < width
                and held[report[1], report[0] - since[report[1]]]
            )
        ]
        sizes = [cells.size for _, _, cells, _ in found]
        return Reply(
            target,
            np.concatenate([c for *_, c, _ in found] or [np.zeros(0)]).astype(np.uint32),
            np.repeat([t for t, *_ in found], sizes).astype(np.uint32),
            np.repeat([s for _, s, *_ in found], sizes).astype(np.uint8),
            np.concatenate([v for *_, v in found] or [np.zeros(0)]).astype(bool),
        )

    def hold_reply(self, env: int, replica: int, reply: Reply) -> int:
        """Hold the reports of a catch-up reply; returns how many keys were new."""
        ticks, senders = reply.ticks.astype(np.int64), reply.aircraft.astype(np.int64)
        cells = reply.cells.astype(np.int64)
        keys = ticks * KEY_AIRCRAFT + senders
        new = 0
        # Entries of one key are one report: they arrive together (reports_since's order).
        starts = np.flatnonzero(np.diff(keys, prepend=-1)).tolist()
        if not starts:
            return 0
        for first, stop in zip(starts, [*starts[1:], keys.size], strict=True):
            new += self.hold(
                env,
                replica,
                int(senders[first]),
                int(ticks[first]),
                cells[first:stop],
                reply.burning[first:stop],
            )
        return new

    # ------------------------------------------------------------------ views
    def first_missing(self, env: int, replica: int, sender: int) -> int:
        """The oldest tick in the replica's window whose report of ``sender`` it lacks (now
        + 1 when none is missing): what a catch-up digest asks from."""
        r = env * self.replicas + replica
        held = self.held[r]
        for tick in range(max(self.window_start(r), 1), int(self.now[r]) + 1):
            if sender not in held.get(tick, ()):
                return tick
        return int(self.now[r]) + 1

    def reports_since(
        self, env: int, replica: int, since: np.ndarray, skip: int
    ) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
        """The reports ``(tick, sender, cells, values)`` the replica holds of each sender
        ``s`` from tick ``since[s]`` on, but for ``skip``'s own, in (tick, sender) order."""
        r = env * self.replicas + replica
        log = self.log[env]
        found = []
        for tick in sorted(self.held[r]):
            for sender in sorted(self.held[r][tick]):
                if sender != skip and sender < since.size and tick >= since[sender]:
                    found.append((tick, sender, *log[tick, sender]))
        return found


__all__ = ["REPLAY_TICKS", "FilteredReplicas", "fire_step_at", "replay_window"]
