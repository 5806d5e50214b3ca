"""CPU seconds per ``train()`` of the RLlib face on RLlib's tuned CartPole, two trees in alternating runs, and
whether the two trees give the same results.

    python benchmarks/studies/rllib_train_cpu.py --before /tmp/main_tree --after . --rounds 3 --iters 5
    python benchmarks/studies/rllib_train_cpu.py --before /tmp/main_tree --after . --check

Each run is a child process with ``PYTHONPATH`` at its tree and ``OMP_NUM_THREADS=1`` that builds the algorithm
from ``benchmarks/peers/rllib_cartpole.py``'s tuned CartPole config (RLlib's ``cartpole_ppo.py`` settings: 2 env
runners, 4,000 env steps per ``train()``) through ``rlchain.rllib`` and times each ``train()`` in the process's
CPU seconds (``time.process_time``: the face trains in a background thread) and in wall seconds. Rounds alternate
the trees' order, so both share the same load; the first ``--warmup`` iterations of each run (imports, first
calls) are left out. Prints each run's per-``train()`` CPU seconds and, per tree, the median and mean over all
timed iterations, with the load average and the CPU's model name (figures under load compare the two trees; they
are not a speed result).

``--check``: one run per tree of ``--iters`` iterations (seed 1) whose result dicts (less the time keys) and
final model weights must be identical.
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import subprocess
import sys
import tempfile

CHILD = r"""
import importlib.util, json, pickle, sys, time
import torch
torch.set_num_threads(1)
tree, iters, warmup, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
spec = importlib.util.spec_from_file_location("rllib_cartpole", tree + "/benchmarks/peers/rllib_cartpole.py")
module = importlib.util.module_from_spec(spec)
spec.loader.exec_module(module)
from rlchain.rllib import alias
alias.install()  # ray.rllib -> rlchain.rllib, as python -m rlchain.rllib does
import rlchain
assert rlchain.__file__.startswith(tree), rlchain.__file__
algo = module.tuned_cartpole_config(1, 2).build_algo()
cpu, wall, results = [], [], []
for i in range(warmup + iters):
    c, w = time.process_time(), time.perf_counter()
    result = algo.train()
    c, w = time.process_time() - c, time.perf_counter() - w
    if i >= warmup:
        cpu.append(c)
        wall.append(w)
    results.append(result)
weights = {k: v.clone() for k, v in algo._stepper.context.model.state_dict().items()}
algo.stop()
with open(out, "wb") as f:
    pickle.dump({"cpu": cpu, "wall": wall, "results": results, "weights": weights}, f)
"""

TIME_KEYS = ("time", "timestamp", "date", "timers", "throughput", "per_sec", "_s", "hostname", "pid", "node_ip")


def run(tree: str, iters: int, warmup: int) -> dict:
    """One child run in ``tree``: its per-``train()`` CPU and wall seconds, result dicts and final weights."""
    tree = os.path.abspath(tree)
    env = {**os.environ, "PYTHONPATH": tree, "OMP_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory(prefix="rllib_train_cpu_") as tmp:
        out = os.path.join(tmp, "out.pkl")
        done = subprocess.run([sys.executable, "-c", CHILD, tree, str(iters), str(warmup), out], env=env, cwd=tmp,
                              capture_output=True, text=True)
        if done.returncode:
            raise SystemExit(f"rllib_train_cpu.py: {tree} failed:\n{done.stderr[-3000:]}")
        with open(out, "rb") as f:
            return pickle.load(f)


def timeless(value, key: str = ""):
    """``value`` without the keys that hold times or rates (they differ between any two runs)."""
    if isinstance(value, dict):
        return {k: timeless(v, k) for k, v in value.items() if not any(t in str(k) for t in TIME_KEYS)}
    if isinstance(value, float) and value != value:
        return "nan"
    return value


def check(before: str, after: str, iters: int) -> bool:
    """Whether the two trees give identical result dicts and final weights over ``iters`` iterations."""
    import torch

    a, b = run(before, iters, 0), run(after, iters, 0)
    same = True
    for i, (ra, rb) in enumerate(zip(a["results"], b["results"])):
        if timeless(ra) != timeless(rb):
            same = False
            ta, tb = timeless(ra), timeless(rb)
            diff = sorted(k for k in set(ta) | set(tb) if ta.get(k) != tb.get(k))
            print(f"iteration {i + 1}: result dicts differ at {diff[:8]}")
    if a["weights"].keys() != b["weights"].keys() or not all(torch.equal(a["weights"][k], b["weights"][k])
                                                             for k in a["weights"]):
        same = False
        print("final weights differ")
    ret = b["results"][-1].get("env_runners", {}).get("episode_return_mean")
    print(f"{iters} iterations: {'IDENTICAL' if same else 'DIFFERENT'} (result dicts less times, "
          f"{len(a['weights'])} weight tensors; last episode_return_mean {ret})")
    return same


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            return next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), "?")
    except OSError:
        return "?"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="the tree to compare against (e.g. a copy of main)")
    parser.add_argument("--after", default=".")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--iters", type=int, default=4, help="timed train() calls per run (or checked ones)")
    parser.add_argument("--warmup", type=int, default=1, help="train() calls per run left out of the timing")
    parser.add_argument("--check", action="store_true", help="compare results and weights instead of timing")
    args = parser.parse_args()
    if args.check:
        sys.exit(0 if check(args.before, args.after, args.iters) else 1)
    cpu = {"before": [], "after": []}
    load = [os.getloadavg()[0]]
    for r in range(args.rounds):
        order = ("before", "after") if r % 2 == 0 else ("after", "before")
        for side in order:
            out = run(getattr(args, side), args.iters, args.warmup)
            cpu[side] += out["cpu"]
            print(f"round {r + 1} {side}: CPU s per train() {' '.join(f'{c:.2f}' for c in out['cpu'])} "
                  f"(wall {' '.join(f'{w:.2f}' for w in out['wall'])})", flush=True)
        load.append(os.getloadavg()[0])
    med = {side: statistics.median(v) for side, v in cpu.items()}
    for side in ("before", "after"):
        print(f"{side}: median {med[side]:.3f} CPU s per train(), mean {statistics.mean(cpu[side]):.3f} "
              f"({len(cpu[side])} iterations)")
    ratio = med["after"] / med["before"]
    print(f"after / before, medians: {ratio:.3f} ({100 * (1 - ratio):.1f}% less CPU); load average (1 min) "
          f"{min(load):.1f}-{max(load):.1f}; {cpu_model()}, {os.cpu_count()} CPUs")


if __name__ == "__main__":
    main()
