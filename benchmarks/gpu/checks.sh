#!/usr/bin/env bash
# The CUDA path on a GPU machine, run first there (docs/benchmarks.md, "On a GPU: NVIDIA H100 and CUDA graphs"):
#   1. the CUDA-only tests (tests skip them without CUDA);
#   2. shipped configs on the GPU: the three tensor-env PPO configs trained to their score_to_win with the
#      seconds it took, then train -> save -> play -> resume of a gymnasium config, SAC, DQN, an LSTM, autocast
#      (bf16, fp16) for a few epochs each: the CUDA paths nothing else runs;
#   3. throughput.py on the tensor envs at 4,096 / 16,384 / 65,536 envs (env-only, rollout, train; eager and
#      bf16 autocast) beside rl_games 2.0 (compile off) on the same env and GPU;
#   4. compile_update against eager at 4,096 envs, a process per env, beside rl_games 2.0 with its default
#      torch_compile.
# Every step has its own timeout and the script goes on after a failure; $OUT gets summary.txt and logs.tgz
# (a log per step and the throughput JSON, re-packed after every step so a run cut short still returns them).
#
#   OUT=/tmp/gpu bash benchmarks/gpu/checks.sh            # on the GPU machine, from the repo root
#   OUT=/tmp/gpu DEVICE=cpu SIZES="256" SECONDS_PER=0.5 bash benchmarks/gpu/checks.sh   # a dry run on a CPU
#
# Needs torch, numpy, pyyaml and tensorboard, plus gymnasium (and tensorboardX and rl_games 2.0's source on
# PYTHONPATH for the rl_games columns; RL_GAMES2_PYTHON= leaves them out).
set -u
OUT=${OUT:-/tmp/gpu_checks}
LOGS=${LOGS:-/tmp/gpu_checks_logs}
mkdir -p "$OUT" "$LOGS"
PY=${PYTHON:-python3}
DEV=${DEVICE:-cuda}
SIZES=${SIZES:-"4096 16384 65536"}
SECONDS_PER=${SECONDS_PER:-1}
RLG2=${RL_GAMES2_PYTHON-$PY}
ENVS=${ENVS:-"TorchCartPole-v0 TorchPendulum-v0 TorchReacher8-v0"}
export PYTHONUNBUFFERED=1 TORCHINDUCTOR_CACHE_DIR=${TORCHINDUCTOR_CACHE_DIR:-/tmp/inductor_cache}
SUMMARY="$OUT/summary.txt"

# shellcheck source=benchmarks/gpu/steps.sh
source "$(dirname "$0")/steps.sh"

say "== $(date -u +%FT%TZ) device=$DEV sizes=[$SIZES]"
describe_machine

# 1. the CUDA-only tests, with the files around them
step tests_cuda 180 "$PY" -m pytest -q -p no:cacheprovider tests/unit/test_tensor_envs.py \
    tests/unit/test_to_device.py tests/unit/test_aux_loss.py tests/unit/test_benchmarks.py
tail -n 3 "$LOGS/tests_cuda.log" | tee -a "$SUMMARY"

# 2. shipped configs on the device: the tensor envs to their score (seconds printed), then short smoke runs
on_dev="params.config.device=$DEV"
RUNS=runs_gpu_checks
rm -rf "$RUNS"
for cfg in torch_cartpole torch_pendulum torch_reacher8; do
    step "learn_$cfg" 150 "$PY" runner.py --train --file "rlchain/configs/ppo_$cfg.yaml" "$on_dev" \
        "params.config.env_config.device=$DEV" "params.config.train_dir=$RUNS"
    grep -E "^stopped|^epoch" "$LOGS/learn_$cfg.log" | tail -n 2 | tee -a "$SUMMARY"
done
step smoke_cartpole_train 90 "$PY" runner.py --train --file rlchain/configs/ppo_cartpole.yaml "$on_dev" \
    params.config.max_epochs=4 "params.config.train_dir=$RUNS/smoke"
ckpt=$(find "$RUNS/smoke" -name '*.pth' | head -n 1)  # its own folder: the learn runs above saved theirs too
say "checkpoint: ${ckpt:-none}"
step smoke_cartpole_play 60 "$PY" runner.py --play --file rlchain/configs/ppo_cartpole.yaml --checkpoint "$ckpt" \
    "$on_dev" --games 3
step smoke_cartpole_resume 90 "$PY" runner.py --train --file rlchain/configs/ppo_cartpole.yaml \
    --checkpoint "$ckpt" "$on_dev" params.config.max_epochs=6 "params.config.train_dir=$RUNS/smoke"
step smoke_sac_pendulum 90 "$PY" runner.py --train --file rlchain/configs/sac_pendulum.yaml "$on_dev" \
    params.config.max_frames=3000 "params.config.train_dir=$RUNS"
step smoke_dqn_cartpole 90 "$PY" runner.py --train --file rlchain/configs/dqn_cartpole.yaml "$on_dev" \
    params.config.max_frames=5000 "params.config.train_dir=$RUNS"
step smoke_lstm 90 "$PY" runner.py --train --file rlchain/configs/ppo_cartpole_masked_velocity_rnn.yaml \
    "$on_dev" params.config.max_epochs=4 "params.config.train_dir=$RUNS"
for mp in bf16 fp16; do
    step "smoke_autocast_$mp" 90 "$PY" runner.py --train --file rlchain/configs/ppo_torch_pendulum.yaml "$on_dev" \
        "params.config.env_config.device=$DEV" "params.config.mixed_precision=$mp" params.config.max_epochs=8 \
        "params.config.train_dir=$RUNS"
done
for f in "$LOGS"/smoke_*.log; do
    grep -m1 -E "Error|error:" "$f" | sed "s|^|$(basename "$f" .log): |" | tee -a "$SUMMARY"
done

# 3. throughput, eager (cuda_graph off; benchmarks/gpu/cuda_graph.sh measures the graphs) and bf16 autocast,
# beside rl_games 2.0 with compile off
cases=()
for env in $ENVS; do for n in $SIZES; do cases+=("torch:$env:$n"); done; done
peer=()
[ -n "$RLG2" ] && peer=(--rl-games2-python "$RLG2" --rl-games-epochs 5 --rl-games-threads 4)  # rl_games' own min(4, cores), as the H100 figures ran
step throughput_eager 330 "$PY" benchmarks/throughput/throughput.py --device "$DEV" --cases "${cases[@]}" \
    --seconds "$SECONDS_PER" --variants eager=params.config.cuda_graph=False \
    bf16=params.config.mixed_precision=bf16,params.config.cuda_graph=False "${peer[@]}" \
    --json "$LOGS/throughput_eager.json"
sed -n '/^backend/,$p' "$LOGS/throughput_eager.log" | tee -a "$SUMMARY"

# 4. compile_update at the first size, a process per env, against eager in the same process (throughput.py
# warms a compiled variant up before timing it), beside rl_games 2.0 with its default torch_compile.
first=${SIZES%% *}
peerc=()
[ -n "$RLG2" ] && peerc=(--rl-games2-python "$RLG2" --rl-games-epochs 6 --rl-games-compile config --rl-games-threads 4)
for env in $ENVS; do
    step "throughput_compile_$env" 150 "$PY" benchmarks/throughput/throughput.py --device "$DEV" --cases "torch:$env:$first" \
        --seconds "$SECONDS_PER" --variants eager=params.config.cuda_graph=False compile=params.config.compile_update=True \
        "${peerc[@]}" --json "$LOGS/throughput_compile_$env.json"
    sed -n '/^backend/,$p' "$LOGS/throughput_compile_$env.log" | tee -a "$SUMMARY"
done
rm -rf "$RUNS"
say "== done $(date -u +%FT%TZ)"
