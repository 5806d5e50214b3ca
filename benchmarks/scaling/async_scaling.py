"""Synchronous runners vs the asynchronous (APPO) learner, simulated: envs whose step costs a sleep.

    python benchmarks/scaling/async_scaling.py                          # 1, 2, 4, 8, 16 workers, ~2 min
    python benchmarks/scaling/async_scaling.py --workers 1 4 --seconds 3 --straggler 10

Every worker steps ``--envs-per-worker`` envs; a vectorized step of worker i costs a sleep of
``--step-ms`` (x ``--straggler`` for worker 0, the straggler), and each env step pauses
``--pause-ms`` with probability ``--pause-prob`` (random hiccups). Sleeping needs no CPU, so the
numbers show the design, not this machine: the policy (a small MLP) still runs for real.
The learner's update is simulated too: a sleep of ``--learner-us`` per frame of its batch.

- sync: rlchain's synchronous runner pattern (``vecenv_type: RAY``): every step waits for every
  worker (threads stepping in lockstep), batched inference in the learner, then the update;
  sampling and learning never overlap.
- appo: rlchain's appo runner pool (``rlchain.algos.appo.local_runners.LocalRunners``, the code
  ``appo.runners: local`` trains with): runner threads with their own policy copy sample
  ``--horizon``-step fragments into the bounded queue; the learner takes ``workers`` fragments per
  batch from whoever is ready, drops fragments more than ``--max-lag`` versions old, "updates",
  publishes new weights every batch.

Columns: sample throughput (env frames/s the learner received), the ideal (the sum of the workers'
own rates, from the sleeps alone), learner utilisation (share of wall time the learner updated),
mean policy lag of the fragments trained on, and fragments dropped as too old.
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import gymnasium as gym
import numpy as np
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)

from benchmarks.common import cpu_model  # noqa: E402
from rlchain.algos.appo.local_runners import LocalRunners  # noqa: E402
from rlchain.config.load import parse_params  # noqa: E402
from rlchain.config.run import EnvRunnersConfig  # noqa: E402
from rlchain.envs.factory import make_vec_env  # noqa: E402
from rlchain.envs.ray.ray_env import worker_slices  # noqa: E402
from rlchain.envs.ray.ray_worker import EnvRecipe  # noqa: E402
from rlchain.models.build import build_model  # noqa: E402

ENV_ID = "rlchain-bench/Sleep-v0"


class SleepEnv(gym.Env):
    """A 4-float observation, 2 actions, reward 1, 200-step episodes; a step may pause (sleep)."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, pause_prob: float = 0.0, pause_s: float = 0.0) -> None:
        self.pause_prob, self.pause_s = pause_prob, pause_s
        self.t = 0

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple:
        super().reset(seed=seed)
        self.t = 0
        return self.np_random.uniform(-1, 1, 4).astype(np.float32), {}

    def step(self, action: int) -> tuple:
        if self.pause_prob and self.np_random.random() < self.pause_prob:
            time.sleep(self.pause_s)
        self.t += 1
        return self.np_random.uniform(-1, 1, 4).astype(np.float32), 1.0, False, self.t >= 200, {}


def config(args: argparse.Namespace, workers: int) -> dict:
    return {"params": {
        "algo": {"name": "appo"}, "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [64, 64]}},
        "config": {"env_name": ENV_ID, "device": "cpu", "num_actors": workers * args.envs_per_worker,
                   "horizon_length": args.horizon, "minibatch_size": args.envs_per_worker * args.horizon,
                   "env_config": {"pause_prob": args.pause_prob, "pause_s": args.pause_ms / 1000},
                   "env_runners": {"num_workers": workers}},
    }}


def delays(args: argparse.Namespace, workers: int) -> list[float]:
    """Seconds of sleep per vectorized step of each worker; worker 0 is the straggler."""
    return [args.step_ms / 1000 * (args.straggler if i == 0 else 1.0) for i in range(workers)]


def ideal_rate(args: argparse.Namespace, workers: int) -> float:
    """Frames/s of the workers on their own: the sum of their rates (pauses included on average)."""
    pause = args.envs_per_worker * args.pause_prob * args.pause_ms / 1000
    return sum(args.envs_per_worker / (d + pause) for d in delays(args, workers))


def run_sync(args: argparse.Namespace, workers: int, model: torch.nn.Module) -> dict:
    """Lockstep: each step waits for every worker, then the learner updates; nothing overlaps."""
    envs = [make_vec_env(ENV_ID, config(args, 1)["params"]["config"]["env_config"], args.envs_per_worker, i,
                         "sync") for i in range(workers)]
    pool = ThreadPoolExecutor(workers)
    wait = delays(args, workers)

    def step(i: int, actions: np.ndarray):
        out = envs[i].step(actions)
        time.sleep(wait[i])
        return out.obs

    try:
        obs = torch.as_tensor(np.concatenate([e.reset(seed=i) for i, e in enumerate(envs)]))
        frames, learner_s, start = 0, 0.0, time.monotonic()
        while time.monotonic() - start < args.seconds:
            for _ in range(args.horizon):
                actions = model.act(obs)["actions"].numpy().reshape(workers, -1)
                obs = torch.as_tensor(np.concatenate(list(pool.map(step, range(workers), actions))))
            batch = workers * args.envs_per_worker * args.horizon
            frames += batch
            t0 = time.monotonic()
            time.sleep(batch * args.learner_us / 1e6)
            learner_s += time.monotonic() - t0
        wall = time.monotonic() - start
    finally:
        pool.shutdown()
        for e in envs:
            e.close()
    return {"throughput": frames / wall, "utilisation": learner_s / wall, "lag": 0.0, "dropped": 0}


def run_appo(args: argparse.Namespace, workers: int, model: torch.nn.Module) -> dict:
    """rlchain's appo runner pool feeding a simulated learner."""
    cfg = config(args, workers)["params"]["config"]
    slices = worker_slices(cfg["num_actors"], EnvRunnersConfig(num_workers=workers))
    recipe = EnvRecipe.capture(ENV_ID, cfg["env_config"], "sync")
    pool = LocalRunners(recipe, slices, 0, args.horizon, args.queue, 0, 60.0, delays(args, workers))
    weights = {k: v.clone() for k, v in model.state_dict().items()}
    try:
        pool.start(model, weights, 0)
        version, frames, learner_s, lags, dropped = 0, 0, 0.0, [], 0
        start = time.monotonic()
        while time.monotonic() - start < args.seconds:
            batch = []
            while len(batch) < workers:
                fragment = pool.get(timeout=1.0)
                if fragment is None:
                    continue
                frames += fragment.frames
                if version - fragment.version > args.max_lag:
                    dropped += 1
                    continue
                batch.append(fragment)
                lags.append(version - fragment.version)
            t0 = time.monotonic()
            time.sleep(sum(f.frames for f in batch) * args.learner_us / 1e6)
            learner_s += time.monotonic() - t0
            version += 1
            pool.publish(weights, version)
        wall = time.monotonic() - start
    finally:
        pool.close()
    return {"throughput": frames / wall, "utilisation": learner_s / wall, "lag": float(np.mean(lags)),
            "dropped": dropped}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4, 8, 16])
    parser.add_argument("--envs-per-worker", type=int, default=4)
    parser.add_argument("--horizon", type=int, default=16, help="fragment / rollout length")
    parser.add_argument("--step-ms", type=float, default=5.0, help="sleep per vectorized step of a worker")
    parser.add_argument("--straggler", type=float, default=5.0, help="worker 0's step costs this many times more")
    parser.add_argument("--pause-prob", type=float, default=0.002, help="chance of a pause per env step")
    parser.add_argument("--pause-ms", type=float, default=100.0)
    parser.add_argument("--learner-us", type=float, default=50.0, help="simulated update cost per frame")
    parser.add_argument("--queue", type=int, default=16, help="appo.learner_queue_size")
    parser.add_argument("--max-lag", type=int, default=4, help="appo.max_policy_lag")
    parser.add_argument("--seconds", type=float, default=6.0, help="per cell")
    args = parser.parse_args()
    gym.register(ENV_ID, entry_point=SleepEnv)
    torch.set_num_threads(1)
    print(f"CPU: {cpu_model()}, {os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f} (start)")
    print(f"{args.envs_per_worker} envs/worker, step {args.step_ms:g} ms/worker (worker 0 x{args.straggler:g}), "
          f"pause {args.pause_ms:g} ms at p={args.pause_prob:g}/env step, horizon {args.horizon}, learner "
          f"{args.learner_us:g} us/frame, {args.seconds:g} s per cell\n")
    print("| workers | ideal frames/s | sync frames/s | appo frames/s | appo/sync | sync learner util | "
          "appo learner util | appo policy lag | appo dropped |")
    print("|---|---|---|---|---|---|---|---|---|")
    for workers in args.workers:
        model = build_model(parse_params(config(args, workers)), SleepEnvSpaces(), torch.device("cpu")).eval()
        sync = run_sync(args, workers, model)
        appo = run_appo(args, workers, model)
        print(f"| {workers} | {ideal_rate(args, workers):,.0f} | {sync['throughput']:,.0f} | "
              f"{appo['throughput']:,.0f} | {appo['throughput'] / sync['throughput']:.2f}x | "
              f"{sync['utilisation']:.0%} | {appo['utilisation']:.0%} | {appo['lag']:.2f} | {appo['dropped']} |",
              flush=True)
    print(f"\nload average {os.getloadavg()[0]:.2f} (end); threads alive {threading.active_count()}")


class SleepEnvSpaces:
    """The spaces build_model needs."""

    observation_space = SleepEnv.observation_space
    action_space = SleepEnv.action_space
    value_size = 1


if __name__ == "__main__":
    main()
