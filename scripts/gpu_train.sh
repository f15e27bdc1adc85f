#!/usr/bin/env bash
# Train the paper's full-resolution belief network on a CUDA machine for a fixed wall-clock
# budget, then evaluate it on the validation seeds.
#
# Made for a borrowed GPU machine that has python3 with torch, numpy, scipy, numba, rich and
# matplotlib but no network and none of the ROS packages: the project's packages are pure
# Python, so they go onto PYTHONPATH as they are (training imports no ROS). Wheels of anything
# else training needs (tensorboardX) may travel in $WHEELS; they are installed into a
# scratch folder first. `wildfire train --time-limit` ends the learning at BUDGET_S seconds
# whatever the iteration count, then evaluates and exports as at the end, so the whole
# script fits its slot.
#
#   scripts/gpu_train.sh                          # on the GPU machine; results in $OUT:
#       train.json (the summary), belief_policy.pt (+ .json), learning_curve.csv
#   DEVICE=cpu ITERATIONS=2 OUT=/tmp/gpu-check scripts/gpu_train.sh --num-envs 2 \
#       --buffer-size 400 --learning-starts 100 --eval-episodes 1 --episode-seconds 4
#                                                 # the same path on this CPU, in seconds
# Options after the script's name go to `wildfire train` after its own (the later one wins).
#
# Afterwards, here: `wildfire eval --policy OUT/belief_policy.pt` (more validation or test
# seeds), or `wildfire train --resume --run-dir ...` / `--init-from OUT/belief_policy.pt`.
set -euo pipefail
cd "$(dirname "$0")/.."

DEVICE=${DEVICE:-cuda}
ITERATIONS=${ITERATIONS:-100000}  # a cap: on one H200 the budget ends the learning first
BUDGET_S=${BUDGET_S:-360}  # learning's share of an 8-minute slot; evaluation takes the rest
WHEELS=${WHEELS:-.whl}
OUT=${OUT:-runs/gpu}
PYTHON=${PYTHON:-python3}
RUN_DIR=${RUN_DIR:-/tmp/wildfire-gpu-run}

packages=("$PWD"/src/wildfire_*)
PYTHONPATH=$(IFS=:; echo "${packages[*]}")${PYTHONPATH:+:$PYTHONPATH}
if compgen -G "$WHEELS/*.whl" >/dev/null; then
    site=$(mktemp -d)
    "$PYTHON" -m pip install -q --no-index --no-deps --no-compile --target "$site" "$WHEELS"/*.whl
    PYTHONPATH=$PYTHONPATH:$site
fi
export PYTHONPATH PYTHONUNBUFFERED=1
mkdir -p "$OUT" "$RUN_DIR"
wildfire=("$PYTHON" -c 'import sys; from wildfire_cli import main; sys.exit(main())')

"$PYTHON" -c 'import torch; print(f"torch {torch.__version__}, cuda available: {torch.cuda.is_available()}")'
[ "$DEVICE" = cpu ] || nvidia-smi --query-gpu=name,memory.total --format=csv,noheader || true

# The belief defaults (epsilon held at 0.5) on the full-resolution network, 32 environments.
# The first GPU run used the observation network's epsilon 1 -> 0.1 and, like every run on
# that schedule, fell late (README, Training). The summary (--json) holds the training
# phase's iterations per second and the final evaluation on the validation seeds.
"${wildfire[@]}" train --approach belief --arch paper --seed 2 \
    --iterations "$ITERATIONS" --num-envs 32 --eval-every 0 --eval-episodes 20 \
    --checkpoint-every 0 --torch-threads 4 --run-dir "$RUN_DIR" \
    --out "$RUN_DIR/belief_policy.pt" --device "$DEVICE" --time-limit "$BUDGET_S" --json "$@" \
    >"$OUT/train.json"
cat "$OUT/train.json"
cp "$RUN_DIR"/belief_policy.pt "$RUN_DIR"/belief_policy.json "$RUN_DIR"/learning_curve.csv "$OUT"/
cp -r "$RUN_DIR"/tensorboard "$OUT"/  # the run's scalars (`tensorboard --logdir OUT`)
# The full-resolution network is ~19 MB and the device machine returns files of at most
# 16 MiB: send it in parts; here, `cat belief_policy.pt.part-* > belief_policy.pt`.
if [ "$(stat -c %s "$OUT/belief_policy.pt")" -gt $((15 * 2 ** 20)) ]; then
    split -b 15M "$OUT/belief_policy.pt" "$OUT/belief_policy.pt.part-" && rm "$OUT/belief_policy.pt"
fi
