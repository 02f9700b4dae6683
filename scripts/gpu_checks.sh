#!/usr/bin/env bash
# The GPU checks of one device session (about 9.5 minutes on one H100), run from the
# repository root on a machine whose image has JAX with CUDA, flax, optax and chex but
# none of sc2jax's other dependencies; those travel as wheels in .whl/ (BUILD.md):
#
#   bash scripts/gpu_checks.sh            # logs into $OUT (default /tmp/gpu_checks)
#
# The wheels carried on 2026-11-27 (Python 3.12, `pip download --no-deps`): rlax, distrax,
# tfp-nightly, decorator, gast, dm-tree, dm-env, websocket-client, s2clientprotocol,
# jaxmarl, gymnax, gymnasium<1.4, farama-notifications, cloudpickle.
#
# Each part has its own time limit and log, so a part that runs out of time or memory
# costs only itself. Parts, most wanted first:
#   1. the simulator at 16,384 environments (issue 3's maps and SMAX-3m, 64², every layer);
#   2. training throughput at 64² (FullyConv and Atari-net, 16 environments, K = 40),
#      and whether acting and learning overlap in one program (--pipelined);
#   3. the simulator at 1,024 environments (the same maps);
#   4. (not by default) the other four maps at 16,384 environments.
# PARTS picks parts by name (default "sim_big train sim_small"; "sim_other" is part 4).
# BIG, SMALL, SIZE and TRAIN_ENVS shrink it for a dry run on a CPU.
set -u
OUT=${OUT:-/tmp/gpu_checks}
BIG=${BIG:-16384}
SMALL=${SMALL:-1024}
SIZE=${SIZE:-64}
TRAIN_ENVS=${TRAIN_ENVS:-16}
PARTS=${PARTS:-sim_big train sim_small}
MAPS=MoveToBeacon,CollectMineralShards,FindAndDefeatZerglings
OTHER=DefeatRoaches,DefeatZerglingsAndBanelings,CollectMineralsAndGas,BuildMarines
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_MEM_FRACTION=0.9

if ls .whl/*.whl >/dev/null 2>&1; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 1
  export PYTHONPATH=/tmp/site:$PWD
fi
nvidia-smi -L 2>&1 | tee "$OUT/machine.log"
python3 -c "
import jax, flax, optax
print('jax', jax.__version__, 'flax', flax.__version__, 'optax', optax.__version__, jax.devices())
import sc2jax.experiments.benchmark, sc2jax.losses.actor_critic, jaxmarl.environments.smax
" 2>&1 | tee -a "$OUT/machine.log"
[ "${PIPESTATUS[0]}" = 0 ] || exit 1

part() {  # part NAME SECONDS ARGS...: one python run, its output in $OUT/NAME.log
  local name=$1 limit=$2
  shift 2
  case " $PARTS " in *" $name "*) ;; *) return ;; esac
  echo "== $name (limit ${limit}s): python3 $*"
  timeout "$limit" python3 "$@" 2>&1 | grep -v -E "^W[0-9]{4}|^$" | tee "$OUT/$name.log"
  echo "== $name exit ${PIPESTATUS[0]}"
}

part sim_big 230 -m sc2jax.experiments.benchmark --maps=$MAPS --num_envs=$BIG --devices=1 \
  --repeats=5 --screen_size=$SIZE --minimap_size=$SIZE
part train 200 -m sc2jax.experiments.benchmark_training --networks=fullyconv,atari \
  --sizes=$SIZE --num_envs=$TRAIN_ENVS --repeats=3 --pipelined
part sim_other 200 -m sc2jax.experiments.benchmark --maps=$OTHER --num_envs=$BIG --devices=1 \
  --repeats=3 --screen_size=$SIZE --minimap_size=$SIZE
part sim_small 110 -m sc2jax.experiments.benchmark --maps=$MAPS --num_envs=$SMALL \
  --devices=1 --repeats=5 --screen_size=$SIZE --minimap_size=$SIZE
