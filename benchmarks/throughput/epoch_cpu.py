"""Rollout and update cost of PPO epochs in wall seconds and in this process's CPU seconds, for two trees.

On a shared, loaded machine wall-clock steps/s swing with the neighbours' load (``tree_compare.py``
alternates rounds to share it out); the CPU seconds a process spends per epoch at one torch thread do
not, so they show what the code costs. Each round runs one child per tree and case, alternating
trees; a child imports the tree it is given, builds the case as ``throughput.py`` does (same
overrides), runs ``--warmup`` epochs (compiling, with ``compile_update``), then times ``--epochs``::

    python benchmarks/throughput/epoch_cpu.py --base-tree /tmp/rlchain_base --cases torch:TorchCartPole-v0:4096 \\
        --rounds 3 --set params.config.compile_update=True

``--set`` overrides apply to this tree only (the base tree may not know the key). The table gives
medians over rounds: CPU ms per epoch of rollout and update, train steps per CPU second, and the
ratio this tree / base of that rate.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

if __package__ in (None, ""):  # run by path: this checkout's benchmarks first
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from benchmarks.common import REPO, throughput_script  # noqa: E402


def child(tree: str, case: str, sets: list[str], warmup: int, epochs: int) -> dict:
    """In a child process: time ``epochs`` PPO epochs of ``case`` with the rlchain of ``tree``."""
    sys.path.insert(0, os.path.dirname(throughput_script(tree)))  # that tree's throughput.py puts its tree first
    import throughput as tp
    import torch

    import rlchain
    if not os.path.abspath(rlchain.__file__).startswith(os.path.abspath(tree) + os.sep):
        raise SystemExit(f"epoch_cpu.py: {tree}'s throughput.py imported {rlchain.__file__}, not that tree's rlchain")

    from rlchain import Runner
    try:  # PPO's class, by its name and file in the tree being timed
        from rlchain.algos.ppo.ppo import PPO
    except ImportError:  # a tree from before the files were named for what they hold
        try:
            from rlchain.algos.ppo.trainer import PPO
        except ImportError:  # a tree from before the algorithms were named for what they are
            from rlchain.algos.ppo.trainer import OnPolicyTrainer as PPO
    from rlchain.models.build import build_env, build_model
    from rlchain.runs.logging import TrainLogger
    from rlchain.training.loop import Loop

    torch.set_num_threads(1)
    backend, env_name, num, config = tp.parse_case(case)
    raw = Runner().load(config).raw
    params = Runner().load(config, tp.overrides(backend, env_name, num, raw, "cpu") + sets).params
    try:  # as training does, in a tree that has it
        from rlchain.parallel.memory import tune_malloc
        tune_malloc(params.malloc)
    except ImportError:  # a tree from before params.malloc
        pass
    torch.manual_seed(0)
    device = torch.device("cpu")
    env = build_env(params, num, 0)
    model = build_model(params, env, device)
    loop = Loop(params, PPO, env, model, device, None, TrainLogger(None, False), 0, raw)
    ppo = loop.algorithm
    obs = torch.as_tensor(env.reset(seed=0), device=device)
    if hasattr(getattr(ppo, "collector", None), "place"):
        ppo.collector.place(obs)
    else:  # a tree from before PPO's collector held where the envs stand
        ppo.obs = obs
    start = time.perf_counter()
    for _ in range(warmup):
        ppo.collect()
        ppo.update()
    warmup_s = time.perf_counter() - start
    cpu = {"rollout": 0.0, "update": 0.0}
    wall = 0.0
    for _ in range(epochs):
        w0, c0 = time.perf_counter(), time.process_time()
        ppo.collect()
        c1 = time.process_time()
        ppo.update()
        c2 = time.process_time()
        wall += time.perf_counter() - w0
        cpu["rollout"] += c1 - c0
        cpu["update"] += c2 - c1
    env.close()
    batch = params.config.horizon_length * num
    return {"rollout_ms": 1e3 * cpu["rollout"] / epochs, "update_ms": 1e3 * cpu["update"] / epochs,
            "cpu_sps": batch * epochs / (cpu["rollout"] + cpu["update"]), "wall_sps": batch * epochs / wall,
            "warmup_s": warmup_s, "tree": tree}


def run_child(tree: str, case: str, sets: list[str], warmup: int, epochs: int) -> dict:
    cmd = [sys.executable, os.path.abspath(__file__), "--child", tree, "--cases", case, "--warmup", str(warmup),
           "--epochs", str(epochs)]
    for item in sets:
        cmd += ["--set", item]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base-tree", help="a checkout of the base revision (git worktree add)")
    ap.add_argument("--cases", nargs="+", required=True, help="BACKEND:ENV:NUM_ENVS[:CONFIG], as throughput.py")
    ap.add_argument("--set", action="append", default=[], help="a config override for this tree only")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=2, help="untimed epochs first (compilation happens here)")
    ap.add_argument("--epochs", type=int, default=8, help="timed epochs per child")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.child, args.cases[0], args.set, args.warmup, args.epochs)))
        return 0
    if not args.base_tree or not os.path.isdir(os.path.join(args.base_tree, "rlchain")):
        raise SystemExit(f"epoch_cpu.py: --base-tree {args.base_tree}: no rlchain package there")
    trees = {"base": (os.path.abspath(args.base_tree), []), "this": (REPO, args.set)}
    results: dict[tuple[str, str], list[dict]] = {}
    for r in range(args.rounds):
        for case in args.cases:
            for name, (tree, sets) in trees.items():
                row = run_child(tree, case, sets, args.warmup, args.epochs)
                results.setdefault((name, case), []).append(row)
                print(f"round {r + 1} {name:4} {case}: cpu {row['rollout_ms']:.1f} + {row['update_ms']:.1f} ms, "
                      f"{row['cpu_sps']:,.0f} steps/cpu-s, wall {row['wall_sps']:,.0f} steps/s, "
                      f"warm-up {row['warmup_s']:.1f} s", flush=True)
    print(f"\n{'case':<34} {'tree':<5} {'rollout cpu ms':>14} {'update cpu ms':>13} {'steps/cpu-s':>12} "
          f"{'wall steps/s':>12} {'warm-up s':>9} {'ratio':>6}")
    for case in args.cases:
        base = statistics.median(x["cpu_sps"] for x in results[("base", case)])
        for name in trees:
            rows = results[(name, case)]
            med = {k: statistics.median(x[k] for x in rows) for k in ("rollout_ms", "update_ms", "cpu_sps",
                                                                      "wall_sps", "warmup_s")}
            print(f"{case:<34} {name:<5} {med['rollout_ms']:>14.1f} {med['update_ms']:>13.1f} {med['cpu_sps']:>12,.0f} "
                  f"{med['wall_sps']:>12,.0f} {med['warmup_s']:>9.1f} {med['cpu_sps'] / base:>6.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
