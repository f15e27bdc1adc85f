"""The code stays lint-clean and formatted (ruff, configured in pyproject.toml)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUFF = Path(sys.executable).with_name("ruff")


@pytest.mark.parametrize("command", [["check"], ["format", "--check"]], ids=["check", "format"])
def test_ruff(command: list[str]) -> None:
    if not RUFF.exists():
        pytest.skip("ruff is not installed in this environment (scripts/setup.sh installs it)")
    done = subprocess.run(
        [str(RUFF), *command, "src", "tests"], cwd=ROOT, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_mypy() -> None:
    """A bare ``mypy`` checks the packages under src/ (configured in pyproject.toml)."""
    mypy = Path(sys.executable).with_name("mypy")
    if not mypy.exists():
        pytest.skip("mypy is not installed in this environment (scripts/setup.sh installs it)")
    done = subprocess.run([str(mypy)], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def test_interface_package_does_not_import_the_runtime() -> None:
    """Dependencies point one way: wildfire_ros builds on wildfire_msgs_py, never the reverse."""
    interface = ROOT / "src" / "wildfire_msgs_py" / "wildfire_msgs_py"
    offenders = [
        f"{path.relative_to(ROOT)}:{number}"
        for path in sorted(interface.rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if "import" in line and "wildfire_ros" in line
    ]
    assert offenders == []
