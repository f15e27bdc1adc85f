"""One aircraft's radio under noisy sensing (no ROS): its messages carry its reports.

With noisy sensing under limited radio links (docs/model.md) the agent decides on its own
filtered replica (``wildfire_belief.filtered_replicas``), fused from its own reports and
every report it heard, as the environment's ``TeamReportRadio`` does for every aircraft.
:class:`AircraftReportRadio` keeps the links of
:class:`~wildfire_agent.aircraft_radio.AircraftLinks` (who hears what, when, the heard poses,
the catch-ups); its payload is the sensor's report windows of the tick:

* on the wire, only the reported bits, every sensor's seen cells in order: the windows follow
  from the sender's pose (``sensor_windows``), so a message whose bit count does not fit
  them is malformed;
* a catch-up digest holds, per sender, the oldest tick of the window the replica lacks; the
  reply carries the reports from there on, one ``(cell, tick, sender, value)`` per reading;
* the replica settles once per tick, after the tick's messages (:meth:`AircraftLinks.hear_due`):
  in lockstep exactly as the environment, in real time whatever the arrival order.
"""

from __future__ import annotations

import numpy as np

from wildfire_agent.aircraft_radio import AircraftLinks, check_replies
from wildfire_agent.aircraft_sensor import sensor_windows
from wildfire_agent.dynamics import AircraftState
from wildfire_belief.filtered_aggregator import report_cells
from wildfire_belief.filtered_replicas import FilteredReplicas, fire_step_at, replay_window
from wildfire_belief.radio import CommModel
from wildfire_msgs_py.belief_codec import published_probability
from wildfire_msgs_py.codecs import VisitWindow
from wildfire_msgs_py.input_guard import DropReason, RejectedMessage
from wildfire_msgs_py.radio_codec import Digest, RadioMessage, Reply, pack_burning
from wildfire_sim.grid import geometry_of

Reports = tuple[VisitWindow, ...]
"""One tick's report windows of an aircraft: one per sensor (camera, or the disc)."""


class AircraftReportRadio(AircraftLinks[Reports]):
    """Aircraft ``k`` of ``n`` under radio ``model`` in the episode of ``seed``, its
    ``sensor`` flipping reports with probability ``p``; its replica starts from the team's
    start belief (``ignition`` and ``fuel_mask``, (H, W), spread over ``preburn_steps``)."""

    def __init__(
        self,
        model: CommModel,
        k: int,
        n: int,
        seed: int,
        sensor: str,
        p: float,
        ignition: np.ndarray,
        fuel_mask: np.ndarray,
        preburn_steps: int,
    ) -> None:
        super().__init__(model, k, n, seed, geometry_of(np.asarray(ignition)))
        self.sensor = sensor
        self.replicas = FilteredReplicas(1, 1, p, self.geometry, replay_window(model), senders=n)
        self.replicas.reset(
            [0], np.asarray(ignition)[None], np.asarray(fuel_mask)[None], preburn_steps
        )

    def payload(self, reports: Reports) -> Reports:
        return reports

    def payload_of(self, message: RadioMessage) -> Reports:
        check_replies(message, self.geometry)
        if (
            message.replies
            and int(max(r.aircraft.max(initial=0) for r in message.replies)) >= self.n
        ):
            raise RejectedMessage(DropReason.OUT_OF_RANGE, "catch-up report of no aircraft")
        pose = AircraftState(
            np.array([[message.x_m]]),
            np.array([[message.y_m]]),
            np.array([[message.heading_rad]]),
            np.array([[message.bank_steps]], dtype=np.int64),
        )
        windows = sensor_windows(self.sensor, pose, self.geometry)
        seen = windows.runs.mask(windows.runs.first.shape[-1])[0, 0]  # (C, side, side)
        count = int(seen.sum())
        if message.bits.size != (count + 7) // 8:
            raise RejectedMessage(
                DropReason.MALFORMED, f"{message.bits.size} bytes of bits for {count} readings"
            )
        values = message.burning(count)
        burning = np.zeros_like(seen)
        burning[seen] = values  # C order of (sensor, row, column): the senders' order
        row0, col0 = int(windows.row0[0, 0]), int(windows.col0[0, 0])
        return tuple(VisitWindow(row0, col0, seen[c], burning[c]) for c in range(seen.shape[0]))

    def bits(self, payload: Reports) -> np.ndarray:
        return pack_burning(report_cells(payload, self.geometry)[1])

    def sections(self, tick: int) -> tuple[tuple[Digest, ...], tuple[Reply, ...]]:
        replicas = self.replicas
        return self.queue.compose_with(
            tick,
            lambda _peer: replicas.digest(0, 0),
            lambda peer, digest: replicas.reply(0, 0, peer, digest),
        )

    def merge_own(self, tick: int, payload: Reports) -> None:
        # The replica's clock follows the ticks flown (one per slot; a skipped slot still
        # counts, so that fire steps stay where the environment has them).
        while int(self.replicas.now[0]) < tick:
            upcoming = int(self.replicas.now[0]) + 1
            self.replicas.tick(np.array([0]), np.array([fire_step_at(upcoming)]))
        self.replicas.hold(0, 0, self.k, tick, *report_cells(payload, self.geometry))

    def merge_heard(self, message: RadioMessage, payload: Reports) -> None:
        cells = report_cells(payload, self.geometry)
        self.replicas.hold(0, 0, message.aircraft, message.tick, *cells)

    def merge_reply(self, reply: Reply) -> None:
        self.replicas.hold_reply(0, 0, reply)

    def settle(self) -> None:
        self.replicas.settle()

    def belief(self) -> tuple[np.ndarray, np.ndarray]:
        """The replica as the belief network sees it: the probability of burning in the
        whole percent of ``/wildfire/belief`` (H, W) float32, and ages in seconds."""
        belief = self.replicas.belief
        shown = published_probability(belief.believed(), belief.probability())
        return shown[0], belief.age_s()[0]


__all__ = ["AircraftReportRadio", "Reports"]
