"""Frames per second of Ray env runners (1 and 2 workers) next to the local backends, in one run.

    python benchmarks/scaling/ray_scaling.py                                   # HalfCheetah-v5, 16 envs
    python benchmarks/scaling/ray_scaling.py --env Pendulum-v1 --num-envs 16 --seconds 5 --epochs 4
    python benchmarks/scaling/ray_scaling.py --backends sync ray2 --json out.json

Backends: ``sync`` (gymnasium SyncVectorEnv in this process), ``async`` (gymnasium
AsyncVectorEnv, one subprocess per env), ``rayN`` (``env_runners: {num_workers: N}``, each worker
a SyncVectorEnv over its slice). Both columns use the same seed and the same envs:

- env-only: ``env.step`` with random actions (pre-drawn), what the backend can deliver;
- train: a PPO run through the Runner (``rlchain/configs/ppo_halfcheetah.yaml``'s network and PPO
  settings, ``num_actors`` = --num-envs, --horizon steps, --epochs epochs); fps = frames / training
  seconds (env and Ray worker start-up excluded, reported apart as ``start s``).

One local Ray is started first (its start-up time is printed) and shared by the Ray rows. The
load average is printed: on a shared machine every number moves with the other jobs.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np
import torch
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)

from rlchain import Runner  # noqa: E402
from rlchain.config.run import EnvRunnersConfig  # noqa: E402
from rlchain.envs.factory import make_vec_env  # noqa: E402


def backend_keys(backend: str) -> dict:
    """The config keys that select ``backend`` (sync, async, rayN)."""
    if backend.startswith("ray"):
        return {"vecenv_type": "sync", "env_runners": {"num_workers": int(backend[3:])}}
    return {"vecenv_type": backend}


def env_only_fps(env_name: str, num_envs: int, backend: str, seconds: float) -> float:
    """Random-action steps per second of the backend alone (after 20 warm-up steps)."""
    keys = backend_keys(backend)
    runners = EnvRunnersConfig(**keys["env_runners"]) if "env_runners" in keys else None
    env = make_vec_env(env_name, {}, num_envs, 0, keys["vecenv_type"], env_runners=runners)
    try:
        env.reset()
        rng = np.random.default_rng(0)
        space = env.action_space
        actions = [rng.uniform(space.low, space.high, (num_envs, *space.shape)).astype(space.dtype)
                   if hasattr(space, "low") else rng.integers(0, space.n, num_envs) for _ in range(16)]
        for i in range(20):
            env.step(actions[i % 16])
        steps, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            env.step(actions[steps % 16])
            steps += 1
        return steps * num_envs / (time.perf_counter() - start)
    finally:
        env.close()


def train_fps(env_name: str, num_envs: int, backend: str, horizon: int, epochs: int) -> tuple[float, float]:
    """(training fps, start-up seconds) of a short PPO run through the Runner."""
    with open(os.path.join(ROOT, "rlchain", "configs", "ppo_halfcheetah.yaml")) as f:
        config = yaml.safe_load(f)
    cfg = config["params"]["config"]
    cfg.update(env_name=env_name, env_config={}, num_actors=num_envs, horizon_length=horizon,
               minibatch_size=num_envs * horizon // 4, max_epochs=epochs, print_stats=False, save_best_after=10**6,
               save_frequency=0, **backend_keys(backend))
    with tempfile.TemporaryDirectory() as tmp:
        cfg["train_dir"] = tmp
        start = time.perf_counter()
        result = Runner().load(config).train(seed=0)
        wall = time.perf_counter() - start
    return result.frames / result.seconds, wall - result.seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="HalfCheetah-v5")
    parser.add_argument("--num-envs", type=int, default=16)
    parser.add_argument("--backends", nargs="+", default=["sync", "async", "ray1", "ray2"])
    parser.add_argument("--seconds", type=float, default=8.0, help="env-only measuring time per backend")
    parser.add_argument("--horizon", type=int, default=64)
    parser.add_argument("--epochs", type=int, default=6)
    parser.add_argument("--json", help="also write the rows here")
    args = parser.parse_args()
    torch.set_num_threads(1)
    print(f"{args.env}, {args.num_envs} envs, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} "
          f"(start)", flush=True)
    if any(b.startswith("ray") for b in args.backends):
        import ray

        start = time.perf_counter()
        ray.init(num_cpus=max(os.cpu_count() or 1, 2), include_dashboard=False, log_to_driver=False)
        print(f"ray {ray.__version__} local start: {time.perf_counter() - start:.1f} s", flush=True)
    rows = []
    for backend in args.backends:
        env_fps = env_only_fps(args.env, args.num_envs, backend, args.seconds)
        fps, startup = train_fps(args.env, args.num_envs, backend, args.horizon, args.epochs)
        rows.append({"backend": backend, "env_only_fps": env_fps, "train_fps": fps, "startup_s": startup})
        print(f"  measured {backend}: env-only {env_fps:,.0f}, train {fps:,.0f}", flush=True)
    base = rows[0]
    print(f"\n| backend | env-only fps | train fps | vs {base['backend']} (env-only / train) | start s |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['backend']} | {r['env_only_fps']:,.0f} | {r['train_fps']:,.0f} | "
              f"{r['env_only_fps'] / base['env_only_fps']:.2f}x / {r['train_fps'] / base['train_fps']:.2f}x | "
              f"{r['startup_s']:.1f} |")
    print(f"\nload average {os.getloadavg()[0]:.2f} (end)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"env": args.env, "num_envs": args.num_envs, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
