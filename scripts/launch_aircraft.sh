#!/usr/bin/env bash
# Start one more aircraft against a running system (real-time mode), as a field operator
# would: scripts/launch_aircraft.sh K N [POLICY] [X Y HEADING]
#   K       index of the new aircraft (namespace /uavK)
#   N       team size the agents were started with (the new aircraft pairs with all)
#   POLICY  rh (default), random or a TorchScript .pt file
#   X Y HEADING  start pose in metres / radians (default: 500 500 0)
# Uses the same ROS_DOMAIN_ID and CYCLONEDDS_URI as the running system (export them first;
# the loopback configuration is the default).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 2 ]; then
  echo "usage: $0 K N [POLICY] [X Y HEADING]" >&2
  exit 2
fi
k=$1; n=$2; policy=${3:-rh}; x=${4:-500.0}; y=${5:-500.0}; heading=${6:-0.0}
export CYCLONEDDS_URI=${CYCLONEDDS_URI:-file://$PWD/config/cyclonedds_loopback.xml}
exec .venv/bin/agent --ros-args -r "__ns:=/uav$k" \
  --params-file src/wildfire_bringup/config/wildfire.yaml \
  -p "aircraft:=$k" -p "n_aircraft:=$n" -p "policy:=$policy" -p mode:=realtime \
  -p "start_x:=$x" -p "start_y:=$y" -p "start_heading:=$heading"
