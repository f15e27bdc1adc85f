"""The shipped Foxglove layout of the live view, built with foxglove-sdk's layout types.

Three panels: the truth (fire map, aircraft with their paths, camera footprints) and the
shared belief (probability of burning; the belief ages as a layer to switch on) side by side,
both seen from above in the ``map`` frame, and the score over time below them.

``docs/foxglove/wildfire.json`` is this layout written out; a test keeps the two equal, so a
renamed channel cannot leave the shipped file behind. Write it again with::

    python -m wildfire_bringup.live_view_layout docs/foxglove/wildfire.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import foxglove.layouts as fl

from wildfire_bringup.live_view import (
    AIRCRAFT_CHANNEL,
    FOOTPRINTS_CHANNEL,
    GRID_FIELDS,
    SCORE_CHANNEL,
)
from wildfire_msgs_py.contract import BELIEF, BELIEF_AGE, FIRE_MAP, MAP_FRAME

VIEW_CENTRE_M = (500.0, 500.0, 0.0)
"""Where the top views look first: the centre of the paper's 1 km map (pan for larger ones)."""
VIEW_DISTANCE_M = 1600.0


def _grid(
    topic: str, gradient: tuple[str, str], visible: bool = True
) -> fl.BaseRendererGridTopicSettings:
    """A grid coloured by its one field, 0..100 from the first colour to the second."""
    return fl.BaseRendererGridTopicSettings(
        visible=visible,
        color_mode="gradient",
        color_field=GRID_FIELDS[topic],
        gradient=gradient,
        min_value=0.0,
        max_value=100.0,
        frame_locked=True,
    )


def _top_view(title: str, topics: dict[str, fl.BaseRendererTopicSettings]) -> fl.ThreeDeePanel:
    return fl.ThreeDeePanel(
        title=title,
        config=fl.ThreeDeeConfig(
            fixed_frame=MAP_FRAME,
            follow_tf=MAP_FRAME,
            follow_mode="follow-none",
            camera_state=fl.ThreeDeeCameraState(
                perspective=False,
                distance=VIEW_DISTANCE_M,
                target=VIEW_CENTRE_M,
                target_offset=VIEW_CENTRE_M,
                phi=0.0,
                theta_offset=0.0,
            ),
            scene=fl.BaseRendererSceneSettings(background_color="#1e1e1e"),
            topics=topics,
        ),
    )


def layout() -> fl.Layout:
    """The live view's layout."""
    aircraft = fl.BaseRendererSceneUpdateTopicSettings(visible=True)
    truth = _top_view(
        "Fire (truth), aircraft and paths",
        {
            FIRE_MAP.name: _grid(FIRE_MAP.name, ("#20202000", "#ff3b1f")),
            AIRCRAFT_CHANNEL: aircraft,
            FOOTPRINTS_CHANNEL: fl.BaseRendererSceneUpdateTopicSettings(visible=True),
        },
    )
    belief = _top_view(
        "Belief (probability of burning)",
        {
            BELIEF.name: _grid(BELIEF.name, ("#20202000", "#ffb000")),
            BELIEF_AGE.name: _grid(BELIEF_AGE.name, ("#2060ff", "#20202000"), visible=False),
            AIRCRAFT_CHANNEL: aircraft,
        },
    )
    score = fl.PlotPanel(
        title="Score",
        config=fl.PlotConfig(
            paths=[fl.PlotSeries(value=f"{SCORE_CHANNEL}.score", label="score")],
        ),
    )
    maps = fl.SplitContainer(
        direction="row",
        items=[fl.SplitItem(content=truth), fl.SplitItem(content=belief)],
    )
    return fl.Layout(
        content=fl.SplitContainer(
            direction="column",
            items=[fl.SplitItem(proportion=3, content=maps), fl.SplitItem(content=score)],
        )
    )


def layout_text() -> str:
    """The layout as the shipped file holds it (indented JSON, one trailing newline)."""
    return json.dumps(json.loads(layout().to_json()), indent=2) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Write the layout to the path given (``docs/foxglove/wildfire.json``)."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m wildfire_bringup.live_view_layout FILE", file=sys.stderr)
        return 2
    Path(args[0]).write_text(layout_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
