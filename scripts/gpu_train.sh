#!/usr/bin/env bash
# Train the paper's full-resolution belief network on a CUDA machine for a fixed number of
# iterations, then evaluate it on the validation seeds.
#
# Made for a borrowed GPU machine that has python3 with torch, numpy, scipy, numba, rich,
# matplotlib and tensorboard but no network and none of the ROS packages: the project's
# packages are pure Python, so they go onto PYTHONPATH as they are (training imports no ROS).
# The run is stopped with SIGTERM at the wall-clock budget whatever the iteration count
# (training checkpoints on SIGTERM, and that checkpoint is resumed only to evaluate and
# export it), so the whole script fits its slot.
#
#   scripts/gpu_train.sh                          # on the GPU machine; results in $OUT:
#       train.json (the summary), belief_policy.pt (+ .json), learning_curve.csv
#   DEVICE=cpu ITERATIONS=2 OUT=/tmp/gpu-check scripts/gpu_train.sh --num-envs 2 \
#       --buffer-size 400 --learning-starts 100 --eval-episodes 1 --episode-seconds 4
#                                                 # the same path on this CPU, in seconds
# Options after the script's name go to `wildfire train` after its own (the later one wins).
#
# Afterwards, here: `wildfire eval --policy OUT/belief_policy.pt` (more validation or test
# seeds), or `wildfire train --init-from OUT/belief_policy.pt ...` to train on.
set -euo pipefail
cd "$(dirname "$0")/.."

DEVICE=${DEVICE:-cuda}
ITERATIONS=${ITERATIONS:-4000}
BUDGET_S=${BUDGET_S:-420}  # training's share of an 8-minute slot; evaluation takes the rest
OUT=${OUT:-runs/gpu}
PYTHON=${PYTHON:-python3}
RUN_DIR=${RUN_DIR:-/tmp/wildfire-gpu-run}

packages=("$PWD"/src/wildfire_*)
PYTHONPATH=$(IFS=:; echo "${packages[*]}")${PYTHONPATH:+:$PYTHONPATH}
export PYTHONPATH PYTHONUNBUFFERED=1
mkdir -p "$OUT" "$RUN_DIR"
wildfire=("$PYTHON" -c 'import sys; from wildfire_cli import main; sys.exit(main())')

"$PYTHON" -c 'import torch; print(f"torch {torch.__version__}, cuda available: {torch.cuda.is_available()}")'
[ "$DEVICE" = cpu ] || nvidia-smi --query-gpu=name,memory.total --format=csv,noheader || true

# The observation network's recipe (README, Training) on the full-resolution belief network.
# The summary (--json) holds the training phase's iterations per second and the final
# evaluation on the validation seeds.
common=(--run-dir "$RUN_DIR" --out "$RUN_DIR/belief_policy.pt" --device "$DEVICE" --json)
status=0
timeout -s TERM "$BUDGET_S" "${wildfire[@]}" train --approach belief --arch paper --seed 2 \
    --iterations "$ITERATIONS" --num-envs 32 --n-step 20 --explore-hold 20 \
    --exploration-samples 200000 --end-e 0.1 --eval-every 0 --eval-episodes 20 \
    --checkpoint-every 0 --torch-threads 4 "${common[@]}" "$@" >"$OUT/train.json" || status=$?
if [ "$status" = 124 ]; then
    # Stopped at the budget: SIGTERM saved a checkpoint; resuming it to the iteration it
    # reached trains no further and evaluates and exports that network.
    read -r done_iterations wall_s < <("$PYTHON" -c 'import sys, pathlib
from wildfire_learning.checkpoint import load_checkpoint
state = load_checkpoint(pathlib.Path(sys.argv[1]))["state"]
print(state["iterations"], round(state["wall_time_s"]))' "$RUN_DIR")
    echo "stopped at the ${BUDGET_S} s budget: $done_iterations iterations in $wall_s s," \
        "the replay prefill included" | tee "$OUT/budget.txt"
    "${wildfire[@]}" train --resume --iterations "$done_iterations" "${common[@]}" \
        >"$OUT/train.json"
elif [ "$status" != 0 ]; then
    exit "$status"
fi
cat "$OUT/train.json"
cp "$RUN_DIR"/belief_policy.pt "$RUN_DIR"/belief_policy.json "$RUN_DIR"/learning_curve.csv "$OUT"/
# The full-resolution network is ~19 MB and the device machine returns files of at most
# 16 MiB: send it in parts; here, `cat belief_policy.pt.part-* > belief_policy.pt`.
if [ "$(stat -c %s "$OUT/belief_policy.pt")" -gt $((15 * 2 ** 20)) ]; then
    split -b 15M "$OUT/belief_policy.pt" "$OUT/belief_policy.pt.part-" && rm "$OUT/belief_policy.pt"
fi
