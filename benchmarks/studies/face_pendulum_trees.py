"""RLlib's tuned Pendulum PPO through the face, in two trees: the same results, and seconds per ``train()``.

    python benchmarks/studies/face_pendulum_trees.py same --before /tmp/base --after .
    python benchmarks/studies/face_pendulum_trees.py seconds --before /tmp/base --after . --rounds 3

Each side runs ``benchmarks/peers/rllib_cartpole.py``'s ``tuned_pendulum_config`` (seed 1) under
``python -m rlchain.rllib`` in its own process, with ``PYTHONPATH`` and the working folder at its tree.

``same``: ``--iterations`` ``train()`` calls at one torch thread in each tree; every result dict (less its
clock readings) and every tensor of the trained model must be equal. Prints one line per iteration and the
verdict; exit status 1 when they differ.

``seconds``: ``--rounds`` rounds, each running the before tree then the after tree (so a change in the
machine's load falls on both), ``--iterations`` ``train()`` calls each; the first is left out (it builds and
warms up). Prints the medians over every timed ``train()`` of each tree: the process's CPU seconds (all its
threads: the training thread, the envs) and wall seconds, with the load average. Threads are each tree's own
plan unless ``--threads`` fixes them.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

CLOCK_WORDS = ("time", "timer", "timestamp", "date", "hostname", "pid", "node_ip", "throughput", "per_sec")
"""Result keys holding readings of the clock or the host, which no two runs share."""


def _update_profile():
    """The sibling ppo_update_profile.py (its ``face_algorithm`` builds the face's Pendulum and catches its PPO)."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ppo_update_profile.py")
    spec = importlib.util.spec_from_file_location("ppo_update_profile", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def without_clock(value):
    """``value`` (a result dict) without the keys that read the clock or the host."""
    if isinstance(value, dict):
        return {k: without_clock(v) for k, v in value.items()
                if not any(word in str(k).lower() for word in CLOCK_WORDS)}
    return value


def child(args: argparse.Namespace) -> None:
    """One side: ``train()`` ``--iterations`` times; one JSON line per call, the model's tensors to ``--out``."""
    import torch

    import rlchain.runner

    if args.threads:  # fix the thread plan (rollout and update) of the run the face starts
        plan = rlchain.runner.set_threads
        rlchain.runner.set_threads = lambda torch_threads, update_threads, *a, **k: plan(
            torch_threads or args.threads, update_threads or args.threads, *a, **k)
    algo, caught = _update_profile().face_algorithm(args.seed)
    for _ in range(args.iterations):
        cpu, wall = time.process_time(), time.perf_counter()
        result = algo.train()
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        print(json.dumps({"cpu": cpu, "wall": wall, "result": without_clock(result)}, default=repr), flush=True)
    if args.out:
        torch.save({k: v.clone() for k, v in caught["ppo"].model.state_dict().items()}, args.out)
    algo.stop()


def run_side(tree: str, args: argparse.Namespace, out: str | None, threads: int | None) -> list[dict]:
    cmd = [sys.executable, "-m", "rlchain.rllib", os.path.abspath(__file__), "child", "--iterations",
           str(args.iterations), "--seed", str(args.seed)]
    if out:
        cmd += ["--out", out]
    if threads:
        cmd += ["--threads", str(threads)]
    env = {**os.environ, "PYTHONPATH": os.path.abspath(tree), "OMP_NUM_THREADS": "1"}
    done = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"{tree}: failed:\n{done.stderr[-3000:]}")
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


def same(args: argparse.Namespace) -> int:
    import torch

    with tempfile.TemporaryDirectory() as tmp:
        sides = {}
        for name, tree in (("before", args.before), ("after", args.after)):
            out = os.path.join(tmp, f"{name}.pt")
            sides[name] = (run_side(tree, args, out, 1), torch.load(out))
    (rows0, weights0), (rows1, weights1) = sides["before"], sides["after"]
    equal = len(rows0) == len(rows1) == args.iterations
    for i, (a, b) in enumerate(zip(rows0, rows1), 1):
        match = a["result"] == b["result"]
        equal &= match
        learner = b["result"].get("learners", {}).get("default_policy", {})
        print(f"iteration {i}: result dicts {'equal' if match else 'DIFFER'} (return "
              f"{b['result'].get('env_runners', {}).get('episode_return_mean')}, policy_loss "
              f"{learner.get('policy_loss')})")
    same_weights = weights0.keys() == weights1.keys() and all(torch.equal(weights0[k], weights1[k])
                                                               for k in weights0)
    print(f"model tensors after {args.iterations} iterations: {'equal' if same_weights else 'DIFFER'} "
          f"({len(weights1)} tensors)")
    return 0 if equal and same_weights else 1


def seconds(args: argparse.Namespace) -> int:
    times = {"before": [], "after": []}
    loads = [os.getloadavg()[0]]
    for _ in range(args.rounds):
        for name, tree in (("before", args.before), ("after", args.after)):
            times[name] += run_side(tree, args, None, args.threads)[1:]
            loads.append(os.getloadavg()[0])
    for name, rows in times.items():
        cpu, wall = [r["cpu"] for r in rows], [r["wall"] for r in rows]
        print(f"{name:6s} ({getattr(args, name)}): per train() median CPU {statistics.median(cpu):.3f} s, wall "
              f"{statistics.median(wall):.3f} s over {len(rows)} train() calls")
    ratio = statistics.median(r["cpu"] for r in times["before"]) / statistics.median(r["cpu"] for r in times["after"])
    print(f"before / after, CPU: {ratio:.2f}x; load average {min(loads):.1f}-{max(loads):.1f} during the runs")
    return 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("same", "seconds", "child"))
    parser.add_argument("--before", default="/work/base")
    parser.add_argument("--after", default=".")
    parser.add_argument("--iterations", type=int, default=None, help="train() calls per run (same: 3, seconds: 6)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--threads", type=int, default=None, help="torch threads of rollout and update")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    if args.iterations is None:
        args.iterations = 3 if args.mode == "same" else 6
    if args.mode == "child":
        child(args)
        return
    sys.exit(same(args) if args.mode == "same" else seconds(args))


if __name__ == "__main__":
    main()
