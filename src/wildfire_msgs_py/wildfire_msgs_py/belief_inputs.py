"""A reader's three belief inputs, checked and mirrored into whole frames (no ROS here).

Every node that needs the shared belief of each tick (agents, the run monitor, the live
view) subscribes to the keyframes (``/wildfire/belief``, ``/wildfire/belief_age_exact``)
and the deltas between them (``/wildfire/belief_delta``) through :func:`belief_inputs`: each
message is checked against the run's geometry (``wire_checks``), handed to one
:class:`~wildfire_msgs_py.belief_delta.BeliefMirror`, and every frame the mirror completes
goes to ``on_frame``, in order of completion.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from wildfire_msgs_py import contract
from wildfire_msgs_py.belief_delta import BeliefMirror, Frame
from wildfire_msgs_py.map_geometry import MapGeometry
from wildfire_msgs_py.wire_checks import (
    checked_age_image,
    checked_belief_delta,
    checked_belief_values,
)

T = TypeVar("T")


def belief_inputs(
    geometry: MapGeometry, on_frame: Callable[[Frame], list[T]]
) -> list[tuple[contract.TopicSpec, Callable[[Any], list[T]]]]:
    """(topic, message handler) of the three belief topics; a handler returns what
    ``on_frame`` returned for the frames its message completed, concatenated."""
    mirror = BeliefMirror()

    def frames(completed: list[Frame]) -> list[T]:
        out: list[T] = []
        for frame in completed:
            out += on_frame(frame)
        return out

    return [
        (
            contract.BELIEF,
            lambda m: frames(mirror.on_key_grid(*checked_belief_values(m, geometry))),
        ),
        (
            contract.BELIEF_AGE_EXACT,
            lambda m: frames(mirror.on_key_ages(*checked_age_image(m, geometry))),
        ),
        (
            contract.BELIEF_DELTA,
            lambda m: frames(mirror.on_delta(checked_belief_delta(m, geometry))),
        ),
    ]


__all__ = ["belief_inputs"]
