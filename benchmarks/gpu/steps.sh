# Shared by benchmarks/gpu/checks.sh and benchmarks/gpu/cuda_graph.sh (sourced): the summary line writer and
# the timed step runner. Needs OUT, LOGS and SUMMARY set.

say() { echo "$*" | tee -a "$SUMMARY"; }

# step NAME SECONDS CMD...: run CMD with a timeout, log to $LOGS/NAME.log (packed into $OUT/logs.tgz after every
# step, so a run cut short still returns what it did), record its exit status and wall seconds
step() {
    local name=$1 limit=$2
    shift 2
    local t0 t1 rc
    t0=$(date +%s.%N)
    timeout "$limit" "$@" >"$LOGS/$name.log" 2>&1
    rc=$?
    t1=$(date +%s.%N)
    say "$(printf '%-28s exit %3d  %7.1f s' "$name" "$rc" "$(python3 -c "print($t1 - $t0)")")"
    tar czf "$OUT/logs.tgz" -C "$LOGS" .
    return $rc
}

# the machine, the GPU and torch, at the top of the summary
describe_machine() {
    { nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader 2>/dev/null || echo "no nvidia-smi"
      lscpu | grep -m1 "Model name"; nproc
      "$PY" -c "import torch, sys; print('python', sys.version.split()[0], 'torch', torch.__version__, 'cuda', \
torch.cuda.is_available(), torch.cuda.get_device_name(0) if torch.cuda.is_available() else '')"
    } 2>&1 | tee -a "$SUMMARY"
}
