#!/usr/bin/env bash
# Set up .venv if needed, then run the whole test suite (slow tests included), then the
# ROS-facing tests (marker `dds`) a second time on the other runtime backend: once on real
# rclpy (Fast DDS) where its wheels are installed, once on our Cyclone DDS layer.
# Each pass runs on two pytest-xdist workers (WILDFIRE_TEST_WORKERS, default 2): the suite is
# mostly multi-process systems that keep one core busy, so two at a time fill two cores.
# Tests that build network namespaces share one worker (xdist_group "netns").
# Extra arguments go to both pytest runs, e.g. scripts/test.sh -m "not slow" -x
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
parallel=(-n "${WILDFIRE_TEST_WORKERS:-2}" --dist loadgroup)
if .venv/bin/python -c 'import rclpy' 2>/dev/null; then
  WILDFIRE_ROS_BACKEND=rclpy .venv/bin/python -m pytest "${parallel[@]}" "$@"
  echo "test: the ROS-facing tests again, on the Cyclone DDS layer (WILDFIRE_ROS_BACKEND=dds)"
  WILDFIRE_ROS_BACKEND=dds .venv/bin/python -m pytest "${parallel[@]}" -m dds "$@"
else
  echo "test: rclpy does not import here: every test runs on the Cyclone DDS layer"
  WILDFIRE_ROS_BACKEND=dds .venv/bin/python -m pytest "${parallel[@]}" "$@"
fi
