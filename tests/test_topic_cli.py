"""``wildfire topic`` and ``wildfire bag`` as a user runs them: separate processes over DDS."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

WILDFIRE = [
    sys.executable,
    "-c",
    "import sys; from wildfire_cli import main; sys.exit(main())",
]


def wildfire(
    args: list[str], env: dict[str, str], timeout: float = 30
) -> subprocess.CompletedProcess:
    """Run the CLI to completion."""
    return subprocess.run(
        [*WILDFIRE, *args], env=env, capture_output=True, text=True, timeout=timeout
    )


@pytest.mark.dds
@pytest.mark.timeout(150)
def test_echo_pub_list_info_across_processes(dds_env: dict[str, str]) -> None:
    echo = subprocess.Popen(
        [
            *WILDFIRE,
            "topic",
            "echo",
            "/uav0/bank_cmd",
            "std_msgs/msg/Float64",
            "--once",
            "--timeout",
            "60",
        ],
        env=dds_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    latched = subprocess.Popen(
        [
            *WILDFIRE,
            "topic",
            "pub",
            "-r",
            "20",
            "-t",
            "6000",  # 5 minutes: outlives the steps below on a loaded machine (killed after)
            "/wildfire/score",
            "std_msgs/msg/Float64",
            "{data: 42.5}",
        ],
        env=dds_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        time.sleep(1.0)
        # The echo process may still be starting (imports, discovery): wait for it to match.
        pub = wildfire(
            [
                *("topic", "pub", "--once", "--wait-matching", "40"),
                *("/uav0/bank_cmd", "std_msgs/msg/Float64", "data: -0.0872"),
            ],
            dds_env,
            timeout=60,
        )
        assert pub.returncode == 0, pub.stderr
        assert "publishing #1: " in pub.stdout
        out, err = echo.communicate(timeout=60)
        assert echo.returncode == 0, err
        assert out == "data: -0.0872\n---\n"

        # Discovery across processes can take seconds on a busy machine: listen longer.
        listing = wildfire(["topic", "list", "-t", "--spin-time", "6"], dds_env)
        assert listing.returncode == 0, listing.stderr
        assert "/wildfire/score [std_msgs/msg/Float64]" in listing.stdout.splitlines()

        # Type discovered from the graph; the contract's transient-local QoS means a late
        # echo still gets the value.
        typed = wildfire(["topic", "echo", "/wildfire/score", "--once", "--timeout", "20"], dds_env)
        assert typed.returncode == 0, typed.stderr
        assert typed.stdout.startswith("data: 42.5\n---")

        info = wildfire(["topic", "info", "/wildfire/score"], dds_env)
        assert info.returncode == 0, info.stderr
        assert "Type: std_msgs/msg/Float64" in info.stdout
        assert "Publisher count: 1" in info.stdout
    finally:
        for process in (echo, latched):
            if process.poll() is None:
                process.kill()
                process.wait()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["topic", "pub", "/x", "std_msgs/msg/Strin", "{}"], "std_msgs/msg/Strin"),
        (["topic", "pub", "/x", "std_msgs/msg/String", "{data: [}"], "malformed YAML"),
        (["topic", "pub", "/x", "std_msgs/msg/String", "[1, 2]"], "expected a YAML mapping"),
        (["topic", "pub", "/x", "std_msgs/msg/String", "{dat: a}"], "field 'dat' does not exist"),
        (["topic", "pub", "/x", "std_msgs/msg/Float64", "{data: fast}"], "expected double"),
        (["topic", "echo", "/x", "nav_msgs/Nope"], "nav_msgs/Nope"),
        (["bag", "info", "/nonexistent/bag"], "no such directory"),
        (["bag", "record", "-o", "/tmp/never"], "either -a/--all or one or more topics"),
        (["topic", "hz", "/x", "--window", "0"], "expected a number >= 1"),
    ],
)
def test_bad_input_gives_one_line_and_nonzero_exit(
    dds_env: dict[str, str], args: list[str], message: str
) -> None:
    result = wildfire(args, dds_env)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert message in result.stderr


@pytest.mark.dds
def test_echo_of_silent_topic_times_out_cleanly(dds_env: dict[str, str]) -> None:
    result = wildfire(
        ["topic", "echo", "/silent", "std_msgs/msg/String", "--timeout", "0.5"], dds_env
    )
    assert result.returncode == 1
    assert "no message on /silent within 0.5 s" in result.stderr


@pytest.mark.dds
@pytest.mark.parametrize("verb", ["echo", "hz"])
def test_sigterm_while_waiting_for_a_topic_ends_cleanly(verb: str, dds_env: dict[str, str]) -> None:
    """A tool stopped by SIGTERM (a service manager, ``timeout``) says so in one line."""
    waiting = subprocess.Popen(
        [*WILDFIRE, "topic", verb, "/not_yet_there"],
        env=dds_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(4.0)  # past start-up: polling the graph for the topic
    waiting.terminate()
    _, stderr = waiting.communicate(timeout=30)
    assert "Traceback" not in stderr
    assert stderr.strip().splitlines() == ["wildfire topic: interrupted"]


def test_bad_ros_domain_is_reported(dds_env: dict[str, str]) -> None:
    env = dict(dds_env, ROS_DOMAIN_ID="900", WILDFIRE_ROS_BACKEND="dds")
    result = wildfire(["topic", "list"], env)
    assert result.returncode == 2
    assert "ROS_DOMAIN_ID='900': expected a whole number 0..232" in result.stderr


def test_bag_info_prints_summary(tmp_path: Path, dds_env: dict[str, str]) -> None:
    from wildfire_msgs_py import codecs
    from wildfire_ros.bag import BagWriter
    from wildfire_ros.runtime import serialize_message as serialize

    with BagWriter(tmp_path / "b") as writer:
        writer.add_topic("/wildfire/score", "std_msgs/msg/Float64")
        for i in range(3):
            writer.write("/wildfire/score", 10**9 * (i + 1), serialize(codecs.score_to_msg(i)))
    result = wildfire(["bag", "info", str(tmp_path / "b")], dds_env)
    assert result.returncode == 0, result.stderr
    assert "Messages:          3" in result.stdout
    assert "Topic: /wildfire/score | Type: std_msgs/msg/Float64 | Count: 3" in result.stdout
    assert "Duration:          2.000s" in result.stdout
    as_json = wildfire(["bag", "info", "--json", str(tmp_path / "b")], dds_env)
    assert '"message_count": 3' in as_json.stdout
