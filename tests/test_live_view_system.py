"""``wildfire run --foxglove``: a WebSocket client that speaks Foxglove's protocol sees the
channels of a running system and decodes its messages, in real time and in lockstep; the
lockstep episode is the one ``wildfire eval`` flies (the live view never touches the
barrier); the run flies on when the live view dies; a taken port is one line before anything
starts.

The real-time test also draws what the client decoded (fire, belief, paths, camera
footprints, score): with ``WILDFIRE_WRITE_DOCS=1`` it writes the picture the documentation
shows, ``docs/foxglove/live_view.png``.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from websockets.exceptions import ConnectionClosed

from foxglove_client import FoxgloveClient, Received
from wildfire_learning.evaluate import evaluate
from wildfire_learning.vec_policies import make_vec_policy
from wildfire_world.env import EnvConfig

pytestmark = [pytest.mark.dds, pytest.mark.timeout(240)]
WILDFIRE = str(Path(sys.executable).parent / "wildfire")
REPO = Path(__file__).resolve().parents[1]
FIRE, BELIEF, SCORE = "/wildfire/fire_map", "/wildfire/belief", "/wildfire/score"
AIRCRAFT, FOOTPRINTS = "/wildfire/aircraft", "/wildfire/camera_footprints"
CHANNELS = {FIRE, BELIEF, "/wildfire/belief_age", AIRCRAFT, FOOTPRINTS, "/tf", SCORE}


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def start_run(tmp_path: Path, env: dict[str, str], port: int, *args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [WILDFIRE, "run", "--aircraft", "2", "--foxglove", str(port), "--json",
         "--log-dir", str(tmp_path / "logs"), *args],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip


def finish(run: subprocess.Popen[str]) -> dict[str, Any]:
    stdout, stderr = run.communicate(timeout=180)
    assert run.returncode == 0, stderr
    summary = json.loads(stdout)
    assert "lost_nodes" not in summary, summary["lost_nodes"]
    return summary


def grid_array(grid: Any) -> np.ndarray:
    """A decoded ``foxglove.Grid`` of one int8 field -> its (rows, cols) values, row 0 south."""
    return np.frombuffer(grid.data, dtype=np.int8).reshape(-1, grid.column_count)


def test_realtime_run_is_watched_live(tmp_path: Path, dds_env: dict[str, str]) -> None:
    port = free_port()
    run = start_run(tmp_path, dds_env, port, "--policy", "random", "--sensor", "camera",
                    "--realtime", "--duration", "20", "--seed", "3")  # fmt: skip
    try:
        with FoxgloveClient(f"ws://127.0.0.1:{port}", connect_timeout_s=60) as client:
            client.wait_for_channels(CHANNELS, 30.0)
            assert client.server_info is not None and client.server_info["name"] == "wildfire"
            client.subscribe(sorted(CHANNELS - {"/wildfire/belief_age", "/tf"}))
            got = client.receive_until({FIRE, BELIEF, AIRCRAFT, FOOTPRINTS, SCORE}, 30.0)
            # On to the end of the flight (the server closes with it): the whole path to draw.
            with contextlib.suppress(ConnectionClosed):
                while run.poll() is None:
                    item = client.receive(30.0)
                    got.setdefault(item.topic, []).append(item)
    finally:
        summary = finish(run)
    assert summary["mode"] == "realtime" and summary["foxglove"] == f"ws://127.0.0.1:{port}"

    fire = got[FIRE][-1].message
    # The size and pose are the run's own map: 100 x 100 cells of 10 m, origin at (0, 0).
    assert (fire.column_count, fire.cell_size.x, fire.pose.position.x) == (100, 10.0, 0.0)
    burning = grid_array(fire)
    assert burning.shape == (100, 100) and set(np.unique(burning)) <= {0, 100}
    assert 0 < (burning == 100).sum() < 2000  # the scenario's fire, far from the borders
    assert fire.fields[0].name == "burning" and fire.timestamp.seconds >= 1
    probability = grid_array(got[BELIEF][-1].message)
    assert probability.min() >= 0 and probability.max() <= 100
    # Every tick's belief, rebuilt from keyframes and deltas: most stamps lie between the
    # keyframes (one a fire step, 2.5 s), and the grid is the run's map.
    stamps = {item.log_time_ns for item in got[BELIEF]}
    between = {s for s in stamps if s % 2_500_000_000}
    assert len(between) >= 50, sorted(stamps)
    assert probability.shape == (100, 100)
    ids = {e.id for update in got[AIRCRAFT] for e in update.message.entities}
    assert {"uav0", "uav1", "uav0/path", "uav1/path"} <= ids
    outlines = [line for u in got[FOOTPRINTS] for e in u.message.entities for line in e.lines]
    assert len(outlines) >= 4 and all(len(line.points) >= 5 for line in outlines if line.points)
    scores = [item.message["score"] for item in got[SCORE]]
    assert scores == sorted(scores) and scores[-1] <= summary["score"]

    picture = draw(got, tmp_path / "live_view.png")
    assert picture.stat().st_size > 20_000
    if os.environ.get("WILDFIRE_WRITE_DOCS") == "1":
        (REPO / "docs" / "foxglove" / "live_view.png").write_bytes(picture.read_bytes())


def test_lockstep_run_is_watched_and_flies_as_eval(tmp_path: Path, dds_env: dict[str, str]) -> None:
    port, seed, duration = free_port(), 4, 200.0
    run = start_run(tmp_path, dds_env, port, "--policy", "random", "--fast", "--seed", str(seed),
                    "--duration", str(duration), "--wind", "0.3,-0.2")  # fmt: skip
    try:
        with FoxgloveClient(f"ws://127.0.0.1:{port}", connect_timeout_s=60) as client:
            client.wait_for_channels({FIRE, SCORE}, 30.0)
            client.subscribe([FIRE, SCORE])
            got = client.receive_until({FIRE, SCORE}, 30.0)
    finally:
        summary = finish(run)
    assert summary["mode"] == "lockstep"
    assert grid_array(got[FIRE][0].message).shape == (100, 100)
    config = EnvConfig(
        n_aircraft=2, shapes=("circular",), wind=(0.3, -0.2), max_duration_s=duration
    )
    reference = evaluate(make_vec_policy("random"), config, [seed]).episodes[0]
    assert summary["score"] == reference.score and summary["decisions"] == reference.decisions


def test_the_run_flies_on_when_the_live_view_dies(tmp_path: Path, dds_env: dict[str, str]) -> None:
    port = free_port()
    run = start_run(tmp_path, dds_env, port, "--policy", "random", "--realtime",
                    "--duration", "10", "--seed", "2")  # fmt: skip
    try:
        with FoxgloveClient(f"ws://127.0.0.1:{port}", connect_timeout_s=60) as client:
            client.wait_for_channels({FIRE}, 30.0)
        os.kill(live_view_pid(run.pid), signal.SIGKILL)
    finally:
        stdout, stderr = run.communicate(timeout=180)
    assert run.returncode == 0, stderr
    summary = json.loads(stdout)
    assert summary["decisions"] == 100 and "live_view" in summary["lost_nodes"]
    assert "node live_view died (signal 9)" in stderr and "flying on" in stderr


def live_view_pid(launcher: int) -> int:
    """The live view started by the launcher ``launcher`` (another run may fly beside it)."""
    out = subprocess.run(["ps", "-eww", "-o", "pid,ppid,args"], capture_output=True, text=True)
    for line in out.stdout.splitlines()[1:]:
        pid, parent, args = [*line.split(None, 2), ""][:3]
        if parent == str(launcher) and "live_view_node" in args:
            return int(pid)
    raise AssertionError("no live view among the launcher's children")


def test_a_taken_port_is_one_line(dds_env: dict[str, str]) -> None:
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        port = holder.getsockname()[1]
        result = subprocess.run(
            [WILDFIRE, "run", "--duration", "5", "--foxglove", str(port)],
            env=dds_env, capture_output=True, text=True, timeout=60,
        )  # fmt: skip
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f"wildfire run: error: --foxglove {port}: cannot listen on 127.0.0.1:{port} "
        "(Address already in use); give another port"
    ]


def draw(got: dict[str, list[Received]], path: Path) -> Path:
    """What the client decoded, drawn as the layout's panels are: truth with aircraft, paths
    and footprints; belief; score over sim time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fire, belief = got[FIRE][-1].message, got[BELIEF][-1].message
    latest: dict[str, Any] = {}
    for update in got[AIRCRAFT]:
        latest.update({e.id: e for e in update.message.entities})
    footprints: dict[str, Any] = {}
    for update in got[FOOTPRINTS]:
        footprints.update({e.id: e for e in update.message.entities})
    figure = plt.figure(figsize=(11, 6.6), dpi=100, facecolor="#1e1e1e")
    grid = figure.add_gridspec(2, 2, height_ratios=(3, 1))
    for column, (message, title, cmap) in enumerate(
        [(fire, "Fire (truth), aircraft and paths", "Reds"),
         (belief, "Belief (probability of burning)", "YlOrBr")]
    ):  # fmt: skip
        axes = figure.add_subplot(grid[0, column], facecolor="#1e1e1e")
        size = message.cell_size.x
        x0, y0 = message.pose.position.x, message.pose.position.y
        values = grid_array(message)
        extent = (x0, x0 + size * values.shape[1], y0, y0 + size * values.shape[0])
        axes.imshow(values, origin="lower", extent=extent, cmap=cmap, vmin=0, vmax=100)
        for entity_id, entity in sorted(latest.items()):
            for line in entity.lines:
                color = (line.color.r, line.color.g, line.color.b)
                axes.plot([p.x for p in line.points], [p.y for p in line.points], color=color)
            for arrow in entity.arrows:
                q, p = arrow.pose.orientation, arrow.pose.position
                heading = 2.0 * np.arctan2(q.z, q.w)
                color = (arrow.color.r, arrow.color.g, arrow.color.b)
                axes.annotate("", (p.x + 40 * np.cos(heading), p.y + 40 * np.sin(heading)),
                              (p.x, p.y), arrowprops={"color": color, "width": 3})  # fmt: skip
                axes.text(p.x + 15, p.y + 15, entity_id, color=color, fontsize=9)
        if column == 0:
            for entity in footprints.values():
                for line in entity.lines:
                    color = (line.color.r, line.color.g, line.color.b)
                    axes.plot([p.x for p in line.points], [p.y for p in line.points], color=color)
        axes.set_title(title, color="white", fontsize=10)
        axes.tick_params(colors="#aaaaaa", labelsize=8)
    plot = figure.add_subplot(grid[1, :], facecolor="#1e1e1e")
    times = np.array([item.message["time_s"] for item in got[SCORE]])
    plot.plot(times - times[0], [item.message["score"] for item in got[SCORE]])
    plot.set_title(f"Score ({SCORE}.score) over the seconds watched", color="white", fontsize=10)
    plot.tick_params(colors="#aaaaaa", labelsize=8)
    figure.tight_layout()
    figure.savefig(path, facecolor=figure.get_facecolor())
    plt.close(figure)
    return path
