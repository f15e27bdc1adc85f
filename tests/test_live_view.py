"""The Foxglove live view's core (wildfire_bringup/live_view.py) without ROS nodes: the
conversions to Foxglove's well-known messages, the channels as a WebSocket client sees and
decodes them, "no client, no cost", and the shipped layout."""

from __future__ import annotations

import importlib
import json
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from foxglove.messages import SceneUpdate

from foxglove_client import FoxgloveClient
from wildfire_bringup.live_view import (
    AIRCRAFT_CHANNEL,
    BELIEF_FEEDS,
    FOOTPRINTS_CHANNEL,
    PATH_PERIOD_NS,
    SCORE_CHANNEL,
    TF_CHANNEL,
    LiveView,
    PathHistory,
    aircraft_entity,
    grid_from_occupancy,
)
from wildfire_bringup.live_view_layout import layout_text
from wildfire_msgs_py.belief_delta import Frame
from wildfire_msgs_py.camera_codec import footprints_to_msg
from wildfire_msgs_py.codecs import (
    VisitWindow,
    belief_age_display,
    grid_to_msg,
    pose_to_odometry,
)
from wildfire_msgs_py.errors import MessageFieldError

REPO = Path(__file__).resolve().parents[1]
FIRE = "/wildfire/fire_map"


def decoded(message: Any) -> Any:
    """A foxglove-sdk message (write-only) read back through Foxglove's compiled protobuf
    schemas (foxglove-schemas-protobuf), as a Foxglove client reads it."""
    name = type(message).__name__
    module = importlib.import_module(f"foxglove_schemas_protobuf.{name}_pb2")
    return getattr(module, name).FromString(message.encode())


def a_grid(
    rows: int = 30, cols: int = 70, stamp_ns: int = 2_500_000_000
) -> tuple[np.ndarray, object]:
    """A fire grid of ``rows`` x ``cols`` 10 m cells, origin off the corner, and its message."""
    values = np.where(np.random.default_rng(rows).random((rows, cols)) < 0.2, 100, 0)
    values[0, 0], values[rows - 1, 0] = 100, 0  # row 0 south: the two ends told apart
    return values, grid_to_msg(values, stamp_ns, resolution=10.0, origin_xy=(-40.0, 25.0))


@pytest.mark.parametrize(("rows", "cols"), [(100, 100), (30, 70), (250, 60)])
def test_grid_keeps_the_message_size_pose_and_rows(rows: int, cols: int) -> None:
    values, msg = a_grid(rows, cols)
    grid = decoded(grid_from_occupancy(msg, "burning"))
    assert grid.column_count == cols and grid.row_stride == cols and grid.cell_stride == 1
    assert (grid.cell_size.x, grid.cell_size.y) == (10.0, 10.0)
    assert (grid.pose.position.x, grid.pose.position.y) == (-40.0, 25.0)
    assert (grid.timestamp.seconds, grid.timestamp.nanos) == (2, 500_000_000)
    assert grid.frame_id == "map" and [f.name for f in grid.fields] == ["burning"]
    cells = np.frombuffer(grid.data, dtype=np.int8).reshape(-1, grid.column_count)
    np.testing.assert_array_equal(cells, values)  # row 0 south in both


def test_grid_refuses_data_that_does_not_fill_it() -> None:
    _, msg = a_grid()
    msg.info.width += 1
    with pytest.raises(MessageFieldError, match="expected width"):
        grid_from_occupancy(msg, "burning")


def test_aircraft_arrow_points_along_the_heading_without_the_bank() -> None:
    heading, bank = math.radians(120.0), math.radians(30.0)
    odom = pose_to_odometry((310.0, 420.0, heading, bank), 3, 7_100_000_000)
    entity = decoded(SceneUpdate(entities=[aircraft_entity(3, odom)])).entities[0]
    q = entity.arrows[0].pose.orientation
    assert (q.x, q.y) == (0.0, 0.0)  # level: the bank is not drawn
    assert math.isclose(2.0 * math.atan2(q.z, q.w), heading, abs_tol=1e-12)
    position = entity.arrows[0].pose.position
    assert (position.x, position.y) == (310.0, 420.0)
    assert entity.id == "uav3" and entity.texts[0].text == "uav3"


def test_path_keeps_a_point_per_period() -> None:
    paths = PathHistory()
    added = [paths.add(0, float(i), 0.0, i * 100_000_000) for i in range(21)]
    assert sum(added) == 21 * 100_000_000 // PATH_PERIOD_NS + 1  # one every 5 decisions
    assert list(paths.points[0])[:2] == [(0.0, 0.0), (5.0, 0.0)]
    paths.clear()
    assert paths.add(0, 9.0, 9.0, 2_100_000_000) and list(paths.points[0]) == [(9.0, 9.0)]


@pytest.fixture
def view() -> Iterator[tuple[LiveView, int]]:
    live = LiveView()
    server = live.start_server(0)
    yield live, server.port
    server.stop()
    live.close()


def test_no_client_no_subscription_no_work(view: tuple[LiveView, int]) -> None:
    live, _ = view
    _, msg = a_grid()
    assert live.wanted() == set()
    assert not live.grid(FIRE, msg)
    assert not live.odometry(0, pose_to_odometry((1.0, 2.0, 0.0, 0.0), 0, 0))
    assert not live.score(3.0)
    assert sum(live.logged.values()) == 0


def _watch(client: FoxgloveClient, live: LiveView, topics: list[str], feeds: set[str]) -> None:
    """Subscribe ``client`` to ``topics`` and wait until the view wants ``feeds``."""
    client.subscribe(topics)
    for _ in range(500):
        if feeds <= live.wanted():
            return
        time.sleep(0.01)
    raise AssertionError(f"the view never wanted {feeds}: {live.wanted()}")


def test_a_client_decodes_every_channel_through_the_advertised_schemas(
    view: tuple[LiveView, int],
) -> None:
    live, port = view
    with FoxgloveClient(f"ws://127.0.0.1:{port}") as client:
        channels = {FIRE, AIRCRAFT_CHANNEL, FOOTPRINTS_CHANNEL, TF_CHANNEL, SCORE_CHANNEL}
        client.wait_for_channels(channels | {"/wildfire/belief", "/wildfire/belief_age"}, 10.0)
        assert client.ws.subprotocol in ("foxglove.sdk.v1", "foxglove.websocket.v1")
        schemas = {topic: client.channels[topic]["schemaName"] for topic in channels}
        assert schemas == {
            FIRE: "foxglove.Grid",
            AIRCRAFT_CHANNEL: "foxglove.SceneUpdate",
            FOOTPRINTS_CHANNEL: "foxglove.SceneUpdate",
            TF_CHANNEL: "foxglove.FrameTransforms",
            SCORE_CHANNEL: "wildfire.Score",
        }
        _watch(client, live, sorted(channels), {FIRE, "odom", "camera/footprints", SCORE_CHANNEL})

        values, grid = a_grid(40, 90, stamp_ns=5_000_000_000)
        odom = pose_to_odometry((100.0, 200.0, 0.5, 0.1), 1, 5_000_000_000)
        seen = np.zeros((12, 8), dtype=bool)
        seen[2:9, 1:6] = True
        footprints = footprints_to_msg(
            [VisitWindow(30, 40, seen, np.zeros_like(seen))], 1, 5_000_000_000
        )
        assert live.grid(FIRE, grid) and live.odometry(1, odom)
        assert live.camera_footprints(1, footprints) and live.score(42.0)
        got = client.receive_until(channels, 10.0)

    fire = got[FIRE][0]
    assert fire.log_time_ns == 5_000_000_000
    assert fire.message.column_count == 90 and fire.message.fields[0].name == "burning"
    rows = np.frombuffer(fire.message.data, dtype=np.int8).reshape(-1, 90)
    np.testing.assert_array_equal(rows, values)
    entities = {e.id: e for e in got[AIRCRAFT_CHANNEL][0].message.entities}
    assert set(entities) == {"uav1", "uav1/path"}  # the first pose starts the path
    assert entities["uav1"].arrows[0].pose.position.x == 100.0
    outline = got[FOOTPRINTS_CHANNEL][0].message.entities[0].lines[0].points
    assert min(p.x for p in outline) == 410.0 and min(p.y for p in outline) == 320.0
    transform = got[TF_CHANNEL][0].message.transforms[0]
    assert (transform.parent_frame_id, transform.child_frame_id) == ("map", "uav1/base_link")
    assert got[SCORE_CHANNEL][0].message == {"score": 42.0, "time_s": 5.0}


def test_the_shipped_layout_is_the_one_the_code_builds() -> None:
    shipped = REPO / "docs" / "foxglove" / "wildfire.json"
    assert shipped.read_text() == layout_text(), (
        "python -m wildfire_bringup.live_view_layout docs/foxglove/wildfire.json"
    )
    panels = json.loads(shipped.read_text())["content"]
    text = json.dumps(panels)
    for topic in (FIRE, "/wildfire/belief", AIRCRAFT_CHANNEL, FOOTPRINTS_CHANNEL):
        assert f'"{topic}"' in text
    assert f"{SCORE_CHANNEL}.score" in text


def test_the_belief_shows_every_tick_from_its_frames(view: tuple[LiveView, int]) -> None:
    """The belief's channels are fed from the keyframes and deltas (every tick), not from the
    keyframes alone: each frame the mirror completes is logged, placed as the maps are."""
    live, port = view
    belief, ages = "/wildfire/belief", "/wildfire/belief_age"
    rng = np.random.default_rng(8)
    frames = [
        Frame(
            stamp=(25 + t) * 100_000_000,
            grid=rng.integers(0, 101, (60, 80)).astype(np.int8),
            age_s=rng.uniform(0.0, 300.0, (60, 80)).astype(np.float32),
        )
        for t in range(3)
    ]
    assert not live.belief_frame(frames[0])  # nobody watches: nothing built
    with FoxgloveClient(f"ws://127.0.0.1:{port}") as client:
        client.wait_for_channels({belief, ages}, 10.0)
        _watch(client, live, [belief, ages], set(BELIEF_FEEDS))
        assert "/wildfire/belief_age" not in live.wanted()  # the display keyframe is not read
        assert all(live.belief_frame(frame) for frame in frames)
        got: dict[str, list[Any]] = {belief: [], ages: []}
        while min(len(v) for v in got.values()) < len(frames):
            item = client.receive(10.0)
            got[item.topic].append(item)
    for frame, shown, aged in zip(frames, got[belief], got[ages], strict=True):
        assert shown.log_time_ns == aged.log_time_ns == frame.stamp
        grid = shown.message
        assert (grid.column_count, grid.cell_size.x, grid.pose.position.x) == (80, 10.0, 0.0)
        assert grid.fields[0].name == "probability" and aged.message.fields[0].name == "age"
        values = np.frombuffer(grid.data, dtype=np.int8).reshape(-1, 80)
        np.testing.assert_array_equal(values, frame.grid)
        age_values = np.frombuffer(aged.message.data, dtype=np.int8).reshape(-1, 80)
        np.testing.assert_array_equal(age_values, belief_age_display(frame.age_s))
