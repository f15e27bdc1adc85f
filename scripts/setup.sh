#!/usr/bin/env bash
# Create .venv and install the pinned dependencies, the real rclpy of ROS 2 Jazzy where its
# wheels exist, and every package under src/.
# Idempotent: a second run only re-checks what is installed.
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv with $($PYTHON --version)"
  "$PYTHON" -m venv .venv
fi

stamp=.venv/.wildfire-setup-stamp
want=$(cat requirements.txt requirements-ros.txt src/*/setup.py | sha256sum | cut -d' ' -f1)
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x .venv/bin/wildfire ]; then
  echo "setup: .venv is up to date"
  exit 0
fi

log=.venv/setup.log
pip_install() {
  # pip's build chatter goes to the log; on failure the log's tail says why.
  if ! .venv/bin/python -m pip install --quiet "$@" >>"$log" 2>&1; then
    tail -n 30 "$log" >&2
    echo "setup: pip install $* failed (full log: $log)" >&2
    exit 1
  fi
}
: >"$log"
pip_install --upgrade pip
pip_install -r requirements.txt
# Real rclpy (the default runtime) where its wheels exist: CPython 3.10-3.13 on x86_64 Linux.
if .venv/bin/python -c 'import platform, sys; sys.exit(not (platform.system() == "Linux"
    and platform.machine() == "x86_64" and (3, 10) <= sys.version_info[:2] <= (3, 13)))'; then
  pip_install -r requirements-ros.txt
else
  echo "setup: no ROS 2 Jazzy wheels for $(.venv/bin/python -c 'import platform; print(platform.system(), platform.machine(), "Python", platform.python_version())'): the Cyclone DDS layer serves (WILDFIRE_ROS_BACKEND=dds)"
fi
# Editable installs: the CLI and the ROS 2 entry points run the working tree's code. Built with
# the setuptools already in .venv: an isolated build installs setuptools afresh for each of the
# ten packages (on a fresh clone, 85 s of this script's 190 s; 20 s without).
pkgs=()
for pkg in src/*/; do pkgs+=(-e "$pkg"); done
isolation=()
if .venv/bin/python -c 'import setuptools' 2>/dev/null; then isolation=(--no-build-isolation); fi
pip_install --no-deps "${isolation[@]}" "${pkgs[@]}"
# A .venv from before the CLI moved to wildfire_cli: uninstalling the old owner of the script
# can remove the one just installed.
[ -x .venv/bin/wildfire ] || pip_install --no-deps --force-reinstall -e src/wildfire_cli
# Compile the planner's and the camera world's kernels once here (numba caches them beside
# their source), not in the first few nodes that would each pay seconds of compilation at
# start-up. One process for all: numba and the packages are imported once, not four times.
.venv/bin/python -c 'import importlib
for kernels in ("wildfire_agent.planner_compiled", "wildfire_agent.camera_kernels",
                "wildfire_belief.belief_kernels", "wildfire_msgs_py.percent_kernels"):
    importlib.import_module(kernels).compile_kernels()'
echo "$want" > "$stamp"
echo "setup: done (.venv/bin/wildfire)"
