#!/usr/bin/env bash
# Set up .venv if needed, then run the whole test suite (slow tests included), then the
# ROS-facing tests (marker `dds`) a second time on the other runtime backend: once on real
# rclpy (Fast DDS) where its wheels are installed, once on our Cyclone DDS layer.
# With two pytest-xdist workers, systems run one at a time on one and in-process tests on the
# other (tests/conftest.py). The Cyclone-layer pass always does; WILDFIRE_TEST_WORKERS=2 makes
# the rclpy pass do so too: it cut the suite from ~15 to ~8.5 min here, but made a rare lockstep
# start-up hang on real rclpy far more likely (README, Testing), so that pass defaults to one.
# Extra arguments go to both pytest runs, e.g. scripts/test.sh -m "not slow" -x
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
parallel=()
if [ "${WILDFIRE_TEST_WORKERS:-1}" -gt 1 ]; then
  parallel=(-n "$WILDFIRE_TEST_WORKERS" --dist loadgroup)
fi
if .venv/bin/python -c 'import rclpy' 2>/dev/null; then
  WILDFIRE_ROS_BACKEND=rclpy .venv/bin/python -m pytest ${parallel[@]+"${parallel[@]}"} "$@"
  echo "test: the ROS-facing tests again, on the Cyclone DDS layer (WILDFIRE_ROS_BACKEND=dds)"
  # This pass starts no rclpy node (the hang was never seen on the Cyclone layer): two workers.
  WILDFIRE_ROS_BACKEND=dds .venv/bin/python -m pytest -n "${WILDFIRE_TEST_WORKERS:-2}" \
    --dist loadgroup -m dds "$@"
else
  echo "test: rclpy does not import here: every test runs on the Cyclone DDS layer"
  WILDFIRE_ROS_BACKEND=dds .venv/bin/python -m pytest ${parallel[@]+"${parallel[@]}"} "$@"
fi
