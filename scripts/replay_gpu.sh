#!/usr/bin/env bash
# Supervised learning from replays on one GPU machine, in one device session (about 9
# minutes): convert the replays in $REPLAYS, time each network's update, then train
# FullyConv and arFullyConv side by side on the one GPU until $TRAIN_SECONDS have passed,
# and evaluate both on the held-out games. Run from the repository root:
#
#   REPLAYS=.replays bash scripts/replay_gpu.sh      # logs and results into $OUT
#
# The machine's image has JAX with CUDA, flax, optax, orbax and chex; sc2jax's other
# dependencies travel as wheels in .whl/ (scripts/gpu_checks.sh), here also array_record,
# grain, s2protocol and mpyq. Each network trains in two legs: a first of $FIRST updates
# measures the loop's own rate (eval.json's train_samples_per_second), and the run is
# resumed up to the number of updates that rate fits into the time left.
# A dry run on a CPU: GPU=0 TRAIN_SECONDS=150 FIRST=3 FINAL=2 SPEED_AGENTS=atari
# PROCESSES=2 REPLAYS=<a few replays> bash scripts/replay_gpu.sh
set -u
OUT=${OUT:-/tmp/replay_gpu}
REPLAYS=${REPLAYS:-.replays}
DATA=${DATA:-/tmp/replays64}
RUNS=${RUNS:-/tmp/replay_runs}
PROCESSES=${PROCESSES:-$(nproc)}
TRAIN_SECONDS=${TRAIN_SECONDS:-270}
FIRST=${FIRST:-1000}
AGENTS=${AGENTS:-fullyconv arfullyconv}
GPU=${GPU:-1}
FINAL=${FINAL:-100}
SPEED_AGENTS=${SPEED_AGENTS:-atari,fullyconv,arfullyconv}
ARGS=${ARGS:-}  # more train_replays flags, e.g. --learning_rate=1e-3
mkdir -p "$OUT" "$RUNS"
export PYTHONUNBUFFERED=1
if [ "$GPU" = 1 ]; then  # Two training processes share the GPU.
  export XLA_PYTHON_CLIENT_PREALLOCATE=false
fi

if [ "$GPU" = 1 ] && ls .whl/*.whl >/dev/null 2>&1; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 1
  export PYTHONPATH=/tmp/site:$PWD
fi
{ nvidia-smi -L; nproc; python3 -c "
import jax, flax, optax, grain, s2protocol
print('jax', jax.__version__, 'flax', flax.__version__, 'optax', optax.__version__, jax.devices())
import sc2jax.experiments.train_replays, sc2jax.experiments.convert_replays
"; } 2>&1 | tee "$OUT/machine.log"
[ "${PIPESTATUS[0]}" = 0 ] || exit 1

echo "== convert $(ls "$REPLAYS" | wc -l) replays, $PROCESSES processes"
start=$(date +%s)
timeout 200 python3 -m sc2jax.experiments.convert_replays --replays="$REPLAYS" \
  --output="$DATA" --processes="$PROCESSES" >"$OUT/convert.log" 2>&1
echo "convert exit $? in $(($(date +%s) - start)) s"; tail -2 "$OUT/convert.log"

echo "== update speed"
timeout 90 python3 scripts/replay_training_speed.py --dataset="$DATA" \
  --networks="$SPEED_AGENTS" --updates=20 --repeats=3 2>&1 \
  | grep -v -E "^W[0-9]{4}|^$" | tee "$OUT/speed.md"

train() {  # train SECONDS AGENT STEPS: train_replays into $RUNS/AGENT, log in $OUT/AGENT.log
  timeout "$1" python3 -m sc2jax.experiments.train_replays --dataset="$DATA" --network="$2" \
    --steps="$3" --eval_every=1000 --eval_batches=8 --final_eval_batches="$FINAL" \
    --checkpoint_every=1000000 --run_dir="$RUNS/$2" $ARGS >>"$OUT/$2.log" 2>&1
  local status=$?
  echo "$2: $3 updates, exit $status"
  return $status
}
echo "== train $AGENTS for ${TRAIN_SECONDS}s"
deadline=$(($(date +%s) + TRAIN_SECONDS))
for agent in $AGENTS; do
  (train "$TRAIN_SECONDS" "$agent" "$FIRST" || exit
   # The updates that leg 1's rate (timed after its compiled first update) fits into the
   # time left, less a minute for compiling again and the final evaluation.
   steps=$(python3 -c "
import json, time
rate = json.load(open('$RUNS/$agent/eval.json'))['train_samples_per_second'] / 64
print($FIRST + max(0, int(0.9 * rate * ($deadline - time.time() - 60))))")
   train $((deadline - $(date +%s) + 60)) "$agent" "$steps") &
done
wait
for agent in $AGENTS; do
  tail -14 "$OUT/$agent.log"
  tar -C "$RUNS/$agent" -czf "$OUT/$agent.tgz" eval.json test.csv train.csv curves.png \
    config.json
done
