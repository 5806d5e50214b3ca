#!/usr/bin/env bash
# mjlab on one GPU: rlchain (cuda_graph off and on) against rsl_rl (mjlab's own train) and rl_games 2.0, on Go1 flat
# velocity and Lift-Cube-Yam with rl_games 2.0's YAMLs: reward against frames and seconds, the seconds each system
# takes to reach each peer's final reward, one summary. Sized to fit one 10-minute device call: 2 tasks x 4 systems,
# EPOCHS each at ENVS envs (benchmarks/peers/mjlab_peers.py runs them one after the other), each run cut at an equal
# share of BUDGET seconds (startup and Warp's kernel compilation included; a cut run keeps the rewards it logged).
#
#   PY=python3 RL_GAMES_SRC=/path/to/rl_games OUT=/tmp/mjlab_gpu bash benchmarks/gpu/mjlab_time_to_reward.sh
#
# Needs a Python with mjlab and a CUDA torch (PY), tensorboardX for rl_games 2.0 and an rl_games 2.0 source
# checkout (RL_GAMES_SRC; without one, rl_games2 is left out). DEVICE=cpu ENVS=8 EPOCHS=2 is the tiny CPU run
# (tests/smoke/test_mjlab_gpu_script.py). Writes $OUT/summary.md (both tasks) and $OUT/<task>/{summary.md,
# runs.json,curves.png}.
set -uo pipefail
cd "$(dirname "$0")/../.."
PY=${PY:-python}
DEVICE=${DEVICE:-cuda:0}
ENVS=${ENVS:-4096}
EPOCHS=${EPOCHS:-50}  # 4.9M frames at 4,096 envs: about 35 s at rl_games 2.0's 145k frames/s on an RTX 4090
SEED=${SEED:-42}
OUT=${OUT:-/tmp/mjlab_time_to_reward}
RL_GAMES_SRC=${RL_GAMES_SRC:-}
TASKS=${TASKS:-"ppo_go1_velocity ppo_lift_cube_yam"}
BUDGET=${BUDGET:-510}  # seconds for every run together: the 10-minute call less setup and the summary

SYSTEMS="rlchain_graph_off,rlchain_graph_on,rsl_rl"
if [ -f "$RL_GAMES_SRC/runner.py" ]; then SYSTEMS="$SYSTEMS,rl_games2"; else echo "no RL_GAMES_SRC: rl_games2 left out"; fi
if [ "$DEVICE" = cpu ]; then SYSTEMS=${SYSTEMS/rlchain_graph_off,rlchain_graph_on/rlchain}; fi  # no CUDA graphs on a CPU

runs=$(( $(echo $TASKS | wc -w) * $(echo "$SYSTEMS" | tr , ' ' | wc -w) ))
TIMEOUT=${TIMEOUT:-$(( BUDGET / runs ))}  # seconds per run
echo "$runs runs of at most $TIMEOUT s: $SYSTEMS on $TASKS"
mkdir -p "$OUT"
"$PY" -c "import torch; print('torch', torch.__version__, 'cuda', torch.cuda.is_available(), torch.cuda.get_device_name(0) if torch.cuda.is_available() else 'cpu')" | tee "$OUT/summary.md"
status=0
for task in $TASKS; do
  "$PY" benchmarks/peers/mjlab_peers.py --config "rlchain/configs/rl_games/$task.yaml" --systems "$SYSTEMS" \
    --seed "$SEED" --device "$DEVICE" --envs "$ENVS" --epochs "$EPOCHS" --rl-games-src "$RL_GAMES_SRC" \
    --python "$PY" --timeout "$TIMEOUT" --out "$OUT/$task" || status=1
  { echo; cat "$OUT/$task/summary.md"; } >> "$OUT/summary.md"
done
cat "$OUT/summary.md"
exit $status
