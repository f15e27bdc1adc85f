#!/usr/bin/env bash
# Set up .venv if needed, then run the main job on the shipped defaults: the distributed
# system (fire simulator, belief aggregator, one agent process per aircraft) with two
# aircraft flown by the shipped belief-based DQN policy (models/belief_policy.pt, TorchScript
# inference in each agent node) around a circular wildfire, in lockstep, for 120 s of
# flight; every topic is recorded to a rosbag2 (MCAP) directory and a picture of the fire,
# the shared belief and the flight paths is written. Loopback-only DDS on a run-unique domain.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
out=${WILDFIRE_DEMO_OUT:-out/demo}
mkdir -p "$out"
bag="$out/bag-$(date +%Y%m%d-%H%M%S)"
.venv/bin/wildfire run --aircraft 2 --policy belief --shape circular --seed 2000000 \
  --duration 120 --fast --record "$bag" --png "$out/episode.png" --log-dir "$out/logs"
.venv/bin/wildfire bag info "$bag"
echo "demo: picture in $out/episode.png, recording in $bag"
