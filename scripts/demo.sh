#!/usr/bin/env bash
# Set up .venv if needed, then run the main job on the shipped defaults:
# two aircraft flown by the receding-horizon baseline around a circular wildfire,
# scored per SPEC 2.7, with a picture of the fire, the shared belief and the flight paths.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
out=${WILDFIRE_DEMO_OUT:-out/demo}
mkdir -p "$out"
.venv/bin/wildfire eval --policy rh --aircraft 2 --shape circular --episodes 1 \
  --seed 1000000 --duration 120 --png "$out/episode.png"
echo "demo: picture in $out/episode.png"
