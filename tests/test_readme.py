"""The README is a guide whose every command runs: each command it shows is run here.

**Which lines are commands.** Every non-blank line of a fenced ```` ```bash ```` block of
README.md that is not a comment; a trailing ``  # ...`` comment is cut off, and a line that
ends in a backslash goes on with the next one. Commands shown in prose or in docs/ are not in
scope. ``test_the_readme_shows_the_commands_tested_here`` asserts that the README's commands
are exactly the keys of ``COMMANDS``, so a command added to the README without a test here
fails (and so does one of ``COMMANDS`` the README no longer shows).

**How each one runs.** In a temporary working folder (``examples/`` links to the
repository's; ``runs/`` is made by the first command that writes there). ``wildfire``
commands get ``--json`` added, to read their summary; those that start no system run in this
process through ``wildfire_cli.main`` (no second torch import). ``wildfire run``, the scripts
run as subprocesses, and the tests that start a system join the system tests'
xdist group (one system at a time, on the system worker of ``scripts/test.sh``). They are
not marked ``dds``: a user runs the README on the default runtime, and the Cyclone pass
already flies every system the tour shows (tests/test_run_system.py). Commands
that would take minutes to hours run shortened, as ``SHORTENED`` lists: each ``(old, new)``
replaces text of the README's command, and fails if ``old`` is no longer in it.

The file also checks the README's length (``MAX_LINES``) and that every relative link of
README.md and docs/**/*.md names an existing file (and, for a ``.md#anchor``, a heading of it).
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from foxglove_client import FoxgloveClient
from wildfire_cli import main as cli_main

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
WILDFIRE = str(Path(sys.executable).with_name("wildfire"))
MAX_LINES = 300

# The README's commands, each with the test below that runs it.
COMMANDS: dict[str, str] = {
    "scripts/demo.sh": "test_demo_script",
    "scripts/test.sh --quick": "test_quick_suite_script",
    "scripts/test.sh": "test_the_full_suite_is_what_ci_runs",
    "wildfire run --aircraft 3 --duration 20 --fast --record runs/demo":
        "test_lockstep_run_and_its_bag",
    "wildfire bag info runs/demo": "test_lockstep_run_and_its_bag",
    "wildfire train --from-bag runs/demo --n-aircraft 3 --iterations 2000 --run-dir runs/from_bag":
        "test_lockstep_run_and_its_bag",
    "wildfire run --aircraft 2 --duration 60 --realtime --foxglove":
        "test_realtime_run_watched_in_foxglove",
    "wildfire eval --policy belief --episodes 3": "test_eval",
    "wildfire report --out runs/report": "test_report",
    "wildfire train --approach belief --arch lite --iterations 20000 --run-dir runs/belief":
        "test_train",
    "wildfire eval --policy examples/stalest_fire_policy.py:StalestFirePolicy --episodes 3":
        "test_your_own_policy",
    "wildfire eval --policy rh --map-size 500,500 --ignitions 3 --aircraft 8 --episodes 1"
    " --duration 60": "test_world_options",
}  # fmt: skip

# Training runs small: 2 environments, a 100-sample prefill, 4 s episodes, one validation episode.
TINY_TRAINING = (
    "--num-envs 2 --buffer-size 400 --learning-starts 100 --batch-size 8 "
    "--eval-episodes 1 --episode-seconds 4 --target-network-frequency 3"
)
# README command -> the replacements that make it short here, (old, new) in its text.
SHORTENED: dict[str, list[tuple[str, str]]] = {
    # The demo's 120 s of flight -> 10 s (the text of scripts/demo.sh runs with it replaced).
    "scripts/demo.sh": [("--duration 120", "--duration 10")],
    # Setup and the selection of the quick tests, not the minute of running them.
    "scripts/test.sh --quick": [("--quick", "--quick --collect-only -q")],
    # Hours of training -> 3 iterations; 2000 iterations from a bag -> 5.
    "wildfire train --approach belief --arch lite --iterations 20000 --run-dir runs/belief":
        [("--iterations 20000", f"--iterations 3 {TINY_TRAINING}")],
    "wildfire train --from-bag runs/demo --n-aircraft 3 --iterations 2000 --run-dir runs/from_bag":
        [("--iterations 2000", f"--iterations 5 {TINY_TRAINING}")],
    # A minute of real time -> 5 s; the default port 8765 -> a free one.
    "wildfire run --aircraft 2 --duration 60 --realtime --foxglove":
        [("--duration 60", "--duration 5"), ("--foxglove", "--foxglove {port}")],
}  # fmt: skip
# `wildfire report --out runs/report` finds the shipped evaluations (docs/results/evaluations)
# in runs/report/evaluations, as the README says a user may copy them: nothing is flown again.
# `scripts/test.sh` itself is not run (this file is part of it): CI runs it, `.ci/run`.


def readme_commands() -> list[str]:
    """The README's commands, by the rule of the module docstring."""
    commands: list[str] = []
    in_bash, pending = False, ""
    for line in README.read_text().splitlines():
        if line.startswith("```"):
            in_bash = line.strip() == "```bash"
            continue
        if not in_bash:
            continue
        text = pending + re.sub(r"\s+#.*$", "", line).strip()
        if text.endswith("\\"):
            pending = text[:-1].rstrip() + " "
            continue
        pending = ""
        if text and not text.startswith("#"):
            commands.append(text)
    return commands


def as_run(command: str, **values: object) -> str:
    """The README's ``command`` as this file runs it (``SHORTENED``)."""
    assert COMMANDS.get(command), f"not a command of COMMANDS: {command}"
    for old, new in SHORTENED.get(command, []):
        assert old in command, (command, old)
        command = command.replace(old, new.format(**values), 1)
    return command


@pytest.fixture
def workdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A user's working folder: ``examples/`` of the repository, ``runs/`` of its own."""
    (tmp_path / "examples").symlink_to(REPO / "examples")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def wildfire(command: str, capsys: pytest.CaptureFixture[str]) -> dict:
    """Run a README ``wildfire`` command in this process; its ``--json`` summary."""
    words = shlex.split(as_run(command))
    assert words[0] == "wildfire"
    capsys.readouterr()
    status = cli_main([*words[1:], "--json"])
    out, err = capsys.readouterr()
    assert status == 0, err
    return json.loads(out)


def wildfire_run(command: str, workdir: Path, env: dict[str, str], **values: object) -> list[str]:
    """The argv of a README ``wildfire run`` command as a subprocess, with ``--json`` and logs."""
    words = shlex.split(as_run(command, **values))
    assert words[:2] == ["wildfire", "run"]
    return [WILDFIRE, *words[1:], "--json", "--log-dir", str(workdir / "logs")]


# --- the README itself ------------------------------------------------------------------------


def test_the_readme_shows_the_commands_tested_here() -> None:
    shown = readme_commands()
    assert len(shown) == len(set(shown)), "a command shown twice"
    assert set(shown) == set(COMMANDS), (
        f"README commands without a test here: {sorted(set(shown) - set(COMMANDS))}; "
        f"tested here but not in the README: {sorted(set(COMMANDS) - set(shown))}"
    )
    tests = {name for name, value in globals().items() if name.startswith("test_")}
    assert set(COMMANDS.values()) <= tests
    assert set(SHORTENED) <= set(COMMANDS)


def test_the_readme_is_a_guide_of_at_most_300_lines() -> None:
    assert len(README.read_text().splitlines()) <= MAX_LINES


def markdown_files() -> list[Path]:
    return [README, *sorted((REPO / "docs").rglob("*.md"))]


def heading_anchors(path: Path) -> set[str]:
    """GitHub's anchors of a Markdown file's headings (fenced code left out)."""
    anchors: set[str] = set()
    seen: dict[str, int] = {}
    fenced = False
    for line in path.read_text().splitlines():
        if line.startswith("```"):
            fenced = not fenced
            continue
        match = re.match(r"#{1,6}\s+(.*)", line)
        if fenced or not match:
            continue
        slug = re.sub(r"[^\w\- ]", "", match.group(1).strip().lower()).replace(" ", "-")
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        anchors.add(slug if count == 0 else f"{slug}-{count}")
    return anchors


def test_every_relative_link_resolves() -> None:
    broken = []
    for page in markdown_files():
        text = re.sub(r"```.*?```", "", page.read_text(), flags=re.DOTALL)
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            resolved = (page.parent / path).resolve() if path else page
            if not resolved.exists():
                broken.append(f"{page.relative_to(REPO)}: {target} (no such file)")
            elif anchor and resolved.suffix == ".md" and anchor not in heading_anchors(resolved):
                broken.append(f"{page.relative_to(REPO)}: {target} (no such heading)")
    assert not broken, "\n".join(broken)


def test_nothing_points_outside_the_project() -> None:
    for page in markdown_files():
        text = page.read_text()
        assert "../shared" not in text, page
        assert not re.search(r"\bSPEC\s*(§|section|\d)", text), page


# --- quick start --------------------------------------------------------------------------------


@pytest.mark.xdist_group("system")
@pytest.mark.timeout(240)
def test_demo_script(tmp_path: Path, dds_env: dict[str, str]) -> None:
    script = REPO / "scripts" / "demo.sh"
    text = script.read_text()
    for old, new in SHORTENED["scripts/demo.sh"]:
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    env = {**dds_env, "WILDFIRE_DEMO_OUT": str(tmp_path / "demo")}
    # bash -c TEXT NAME: $0 is the script's own path, so it finds the repository as it does.
    done = subprocess.run(
        ["bash", "-c", text, str(script)], env=env, capture_output=True, text=True, timeout=220
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert (tmp_path / "demo" / "episode.png").stat().st_size > 10_000
    (bag,) = (tmp_path / "demo").glob("bag-*")
    assert (bag / "metadata.yaml").is_file()
    assert "Topic: /wildfire/belief" in done.stdout  # `wildfire bag info` of the recording
    assert f"demo: picture in {tmp_path / 'demo'}/episode.png" in done.stdout


@pytest.mark.timeout(120)
def test_quick_suite_script() -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    words = shlex.split(as_run("scripts/test.sh --quick"))
    done = subprocess.run(
        [str(REPO / words[0]), *words[1:]], cwd=REPO, env=env, capture_output=True, text=True,
        timeout=110,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    collected = re.search(r"(\d+)/(\d+) tests collected \((\d+) deselected\)", done.stdout)
    assert collected, done.stdout[-2000:]
    chosen, total, _ = map(int, collected.groups())
    assert 0 < chosen < total
    assert "tests/test_run_params.py::" in done.stdout  # its one lockstep system
    assert "tests/test_readme.py::" not in done.stdout


def test_the_full_suite_is_what_ci_runs() -> None:
    """`scripts/test.sh` runs this file, so it is not run here: CI runs it, without --quick."""
    ci = (REPO / ".ci" / "run").read_text().splitlines()
    assert "scripts/test.sh" in [line.strip() for line in ci]
    assert not any("--quick" in line for line in ci)


# --- the tour -----------------------------------------------------------------------------------


@pytest.mark.xdist_group("system")
@pytest.mark.timeout(240)
def test_lockstep_run_and_its_bag(
    workdir: Path, dds_env: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    command = "wildfire run --aircraft 3 --duration 20 --fast --record runs/demo"
    done = subprocess.run(
        wildfire_run(command, workdir, dds_env), cwd=workdir, env=dds_env,
        capture_output=True, text=True, timeout=200,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(done.stdout)
    assert summary["mode"] == "lockstep" and summary["aircraft"] == 3
    assert summary["flight_time_s"] == 20.0 and summary["score"] > 0
    assert "lost_nodes" not in summary

    info = wildfire("wildfire bag info runs/demo", capsys)
    assert info["storage"] == "mcap" and info["duration_s"] == 20.0
    assert {"/uav2/odom", "/wildfire/fire_map"} <= {t["name"] for t in info["topics"]}

    from_bag = "wildfire train --from-bag runs/demo --n-aircraft 3 --iterations 2000"
    trained = wildfire(f"{from_bag} --run-dir runs/from_bag", capsys)
    assert trained["iterations"] == 5 and trained["transitions"] == 3 * 200
    assert (workdir / "runs" / "from_bag" / "obs_policy.pt").is_file()


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.mark.xdist_group("system")
@pytest.mark.timeout(240)
def test_realtime_run_watched_in_foxglove(workdir: Path, dds_env: dict[str, str]) -> None:
    """Headless: a Foxglove protocol client (tests/foxglove_client.py) stands in for the app."""
    port = free_port()
    command = "wildfire run --aircraft 2 --duration 60 --realtime --foxglove"
    run = subprocess.Popen(
        wildfire_run(command, workdir, dds_env, port=port), cwd=workdir, env=dds_env,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        with FoxgloveClient(f"ws://127.0.0.1:{port}", connect_timeout_s=60) as client:
            client.wait_for_channels({"/wildfire/fire_map", "/wildfire/score"}, 30.0)
            client.subscribe(["/wildfire/score"])
            got = client.receive_until({"/wildfire/score"}, 30.0)
    finally:
        stdout, stderr = run.communicate(timeout=180)
    assert run.returncode == 0, stderr[-3000:]
    summary = json.loads(stdout)
    assert summary["mode"] == "realtime" and summary["foxglove"] == f"ws://127.0.0.1:{port}"
    assert "lost_nodes" not in summary
    assert got["/wildfire/score"][-1].message["score"] <= summary["score"]


def test_eval(workdir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    summary = wildfire("wildfire eval --policy belief --episodes 3", capsys)
    assert summary["policy"] == "belief" and summary["seeds"] == [2000000, 2000001, 2000002]
    assert len(summary["scores"]) == 3 and summary["score_mean"] > 0


def headline_table() -> dict[tuple[str, str], str]:
    """(scenario key, policy) -> its cell, from the README's headline table."""
    policies = {
        "observation DQN": "obs", "belief DQN": "belief", "receding horizon (`rh`)": "rh",
        "paper's receding horizon (`rh-paper`)": "rh-paper", "random": "random",
    }  # fmt: skip
    rows = [line for line in README.read_text().splitlines() if line.startswith("| ")]
    header = [cell.strip() for cell in rows[0].strip("|").split("|")]
    assert header[:2] == ["scenario", "ceiling"], header
    cells = {}
    for row in rows[1:]:
        values = [cell.strip() for cell in row.strip("|").split("|")]
        scenario = re.fullmatch(r"(\w+), (\d) aircraft", values[0])
        assert scenario, values[0]
        shape, aircraft = scenario.groups()
        for name, value in zip(header, values, strict=True):
            if name in policies:
                cells[(f"{shape.lower()}_{aircraft}aircraft", policies[name])] = value
    return cells


def test_report(workdir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copytree(REPO / "docs" / "results" / "evaluations", workdir / "runs/report/evaluations")
    summary = wildfire("wildfire report --out runs/report", capsys)
    assert summary["evaluated"] == [] and summary["reused"]  # nothing flown again
    for name in ("results.md", "results.json", "scores.png"):
        assert (workdir / "runs" / "report" / name).stat().st_size > 500, name
    # The README's headline table is this report's (rounded to one decimal, so +- 0.05).
    table = headline_table()
    assert len(table) == 25
    for (scenario, policy), cell in table.items():
        got = summary["cells"][scenario][policy]
        parts = re.fullmatch(r"([\d.]+) \+- ([\d.]+) \((?:([\d.]+)x, )?(\d+) %\)", cell)
        assert parts, cell
        mean, sem, ratio, percent = parts.groups()
        assert abs(got["mean"] - float(mean)) <= 0.051, (scenario, policy)
        assert abs(got["sem"] - float(sem)) <= 0.051, (scenario, policy)
        assert round(100 * got["ceiling_fraction"]) == int(percent), (scenario, policy)
        if ratio is not None:
            assert round(got["ratio"], 2) == float(ratio), (scenario, policy)


def test_train(workdir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    command = (
        "wildfire train --approach belief --arch lite --iterations 20000 --run-dir runs/belief"
    )
    summary = wildfire(command, capsys)
    assert summary["iterations"] == 3
    policy = workdir / "runs" / "belief" / "belief_policy.pt"
    card = json.loads(policy.with_suffix(".json").read_text())
    assert card["approach"] == "belief" and card["iterations"] == 3


def test_your_own_policy(workdir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    command = (
        "wildfire eval --policy examples/stalest_fire_policy.py:StalestFirePolicy --episodes 3"
    )
    summary = wildfire(command, capsys)
    assert len(summary["scores"]) == 3 and summary["score_mean"] > 0


def test_world_options(workdir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    command = (
        "wildfire eval --policy rh --map-size 500,500 --ignitions 3 --aircraft 8 --episodes 1"
        " --duration 60"
    )
    summary = wildfire(command, capsys)
    assert summary["aircraft"] == 8 and summary["ignitions"] == 3
    assert summary["flight_time_s"][0] > 0 and summary["scores"][0] > 0  # a fire away from the edge
