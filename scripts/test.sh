#!/usr/bin/env bash
# Set up .venv if needed, then run the whole test suite (slow tests included), then the
# ROS-facing tests (marker `dds`) a second time on the other runtime backend: once on real
# rclpy (Fast DDS) where its wheels are installed, once on our Cyclone DDS layer.
# Both passes run on two pytest-xdist workers (WILDFIRE_TEST_WORKERS=1: one by one): systems
# run one at a time on one worker and in-process tests on the other (tests/conftest.py).
# Extra arguments go to both pytest runs, e.g. scripts/test.sh -m "not slow" -x
#
# scripts/test.sh --quick: the edit loop's few minutes, one pass on the default backend over the
# tests of marker `quick` (tests/conftest.py QUICK_MODULES: a module or two of every package,
# one lockstep system included), slow ones left out. CI runs the full suite, without --quick.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
if [ "${1:-}" = "--quick" ]; then
  quick=1
  shift
fi
scripts/setup.sh
workers="${WILDFIRE_TEST_WORKERS:-2}"
# The slowest tests of each pass are listed at its end: where the suite's time goes.
pytest_args=(--durations=15)
if [ "$workers" -gt 1 ]; then
  pytest_args+=(-n "$workers" --dist loadgroup)
fi
if [ "$quick" = 1 ]; then
  .venv/bin/python -m pytest "${pytest_args[@]}" -m "quick and not slow" "$@"
elif .venv/bin/python -c 'import rclpy' 2>/dev/null; then
  WILDFIRE_ROS_BACKEND=rclpy .venv/bin/python -m pytest "${pytest_args[@]}" "$@"
  echo "test: the ROS-facing tests again, on the Cyclone DDS layer (WILDFIRE_ROS_BACKEND=dds)"
  WILDFIRE_ROS_BACKEND=dds .venv/bin/python -m pytest "${pytest_args[@]}" -m dds "$@"
else
  echo "test: rclpy does not import here: every test runs on the Cyclone DDS layer"
  WILDFIRE_ROS_BACKEND=dds .venv/bin/python -m pytest "${pytest_args[@]}" "$@"
fi
