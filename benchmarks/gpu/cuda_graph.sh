#!/usr/bin/env bash
# cuda_graph on a GPU (docs/benchmarks.md, "On a GPU: NVIDIA H100 and CUDA graphs"): the CUDA-only tests, then the three
# tensor-env PPO configs trained to their score_to_win eager and with cuda_graph (seconds printed), then
# throughput.py at 4,096 / 16,384 / 65,536 envs: eager against cuda_graph in the same process, beside
# rl_games 2.0 (compile off) on the same env and GPU. Every step has its own timeout and the script goes on
# after a failure; $OUT gets summary.txt and logs.tgz.
#
#   OUT=/tmp/g bash benchmarks/gpu/cuda_graph.sh                                   # on the GPU machine
#   OUT=/tmp/g DEVICE=cpu SIZES=256 SECONDS_PER=0.3 bash benchmarks/gpu/cuda_graph.sh   # a dry run on a CPU
#
# Needs what benchmarks/gpu/checks.sh needs (gymnasium; tensorboardX and rl_games 2.0's source on
# PYTHONPATH for the rl_games column, RL_GAMES2_PYTHON= leaves it out).
set -u
OUT=${OUT:-/tmp/gpu_graph}
LOGS=${LOGS:-/tmp/gpu_graph_logs}
mkdir -p "$OUT" "$LOGS"
PY=${PYTHON:-python3}
DEV=${DEVICE:-cuda}
SIZES=${SIZES:-"4096 16384 65536"}
SECONDS_PER=${SECONDS_PER:-1}
RLG2=${RL_GAMES2_PYTHON-$PY}
ENVS=${ENVS:-"TorchCartPole-v0 TorchPendulum-v0 TorchReacher8-v0"}
VARIANTS=${VARIANTS:-"eager=params.config.cuda_graph=False graph=params.config.cuda_graph=True"}
BASE_VARIANTS=${BASE_VARIANTS:-$VARIANTS}
LEARN=${LEARN:-"torch_cartpole torch_pendulum torch_reacher8"}
LEARN_VARIANTS=${LEARN_VARIANTS:-"eager graph"}
export PYTHONUNBUFFERED=1
SUMMARY="$OUT/summary.txt"

# shellcheck source=benchmarks/gpu/steps.sh
source "$(dirname "$0")/steps.sh"

say "== $(date -u +%FT%TZ) device=$DEV sizes=[$SIZES]"
describe_machine

step tests_cuda 240 "$PY" -m pytest -q -p no:cacheprovider tests/unit/test_cuda_graph.py tests/unit/test_to_device.py \
    tests/unit/test_tensor_envs.py tests/unit/test_aux_loss.py tests/unit/test_mixed_precision.py
tail -n 3 "$LOGS/tests_cuda.log" | tee -a "$SUMMARY"

RUNS=runs_gpu_graph
rm -rf "$RUNS"
for cfg in $LEARN; do  # the same seed eager and with cuda_graph: seconds to score_to_win
    for variant in $LEARN_VARIANTS; do
        extra=(params.config.cuda_graph=False)
        [ "$variant" = graph ] && extra=(params.config.cuda_graph=True)
        step "learn_${variant}_$cfg" 150 "$PY" runner.py --train --file "rlchain/configs/ppo_$cfg.yaml" \
            "params.config.device=$DEV" "params.config.env_config.device=$DEV" "${extra[@]}" \
            "params.config.train_dir=$RUNS"
        { grep -m2 "cuda_graph:" "$LOGS/learn_${variant}_$cfg.log"
          grep -E "^stopped|^epoch|Error" "$LOGS/learn_${variant}_$cfg.log" | tail -n 2; } | tee -a "$SUMMARY"
    done
done

cases=()
for env in $ENVS; do for n in $SIZES; do cases+=("torch:$env:$n"); done; done
peer=()
[ -n "$RLG2" ] && peer=(--rl-games2-python "$RLG2" --rl-games-epochs 5 --rl-games-threads 4)  # rl_games' own min(4, cores), as the H100 figures ran
# shellcheck disable=SC2086
step throughput_graph 330 "$PY" benchmarks/throughput/throughput.py --device "$DEV" --cases "${cases[@]}" \
    --seconds "$SECONDS_PER" --variants $VARIANTS "${peer[@]}" --json "$LOGS/throughput_graph.json"
sed -n '/^backend/,$p' "$LOGS/throughput_graph.log" | tee -a "$SUMMARY"
# BASE=DIR: a checkout of an earlier commit (its rlchain/ and its throughput.py, in benchmarks/throughput/ or, in a
# checkout from before the benchmarks were grouped into folders, benchmarks/): the same variants
# at the first size, so a change's gain is measured on this machine in this run
if [ -n "${BASE:-}" ]; then
    first=${SIZES%% *}
    base_script="$BASE/benchmarks/throughput/throughput.py"
    [ -f "$base_script" ] || base_script="$BASE/benchmarks/throughput.py"
    base_cases=()
    for env in $ENVS; do base_cases+=("torch:$env:$first"); done
    # shellcheck disable=SC2086
    step throughput_base 200 "$PY" "$base_script" --device "$DEV" --cases "${base_cases[@]}" \
        --seconds "$SECONDS_PER" --variants $BASE_VARIANTS --json "$LOGS/throughput_base.json"
    sed -n '/^backend/,$p' "$LOGS/throughput_base.log" | tee -a "$SUMMARY"
fi
rm -rf "$RUNS"
say "== done $(date -u +%FT%TZ)"
