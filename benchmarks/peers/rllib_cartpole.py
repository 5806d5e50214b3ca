"""RLlib's tuned CartPole and Pendulum PPO examples (``rllib/examples/algorithms/ppo/cartpole_ppo.py``'s and
``pendulum_ppo.py``'s settings) under real RLlib and through rlchain's face, one after the other: seconds and env
steps to the example's own stop reward (CartPole 450; Pendulum -300, giving up at its 400,000 env steps).

    python benchmarks/peers/rllib_cartpole.py --rllib-python /work/peers/rllib/bin/python --seeds 1 2 3
    python benchmarks/peers/rllib_cartpole.py --example pendulum --seeds 1 2 3

runs, for each seed, this same file as an RLlib script twice: with the side venv's Python (real RLlib 2.60:
``pip install "ray[rllib]==2.60.0"`` in it) and with ``python -m rlchain.rllib`` in this environment. Each run
prints one JSON line (library, seed, seconds of ``train()`` calls until ``episode_return_mean`` >= 450, env steps
then, final return); the driver prints them and the medians. Run it on an otherwise idle machine: Ray's
processes lose far more to other load than one process does, so a loaded run misleads.
``--worker`` is the script itself (what each side runs); its imports are RLlib's own.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

STOP_REWARD = 450.0
MAX_STEPS = 1_000_000


def tuned_cartpole_config(seed: int, runners: int):
    """RLlib's tuned CartPole PPO (``cartpole_ppo.py``'s settings), imported from whichever ``ray.rllib`` the
    process has: real RLlib, or rlchain's face under ``python -m rlchain.rllib``."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    return (PPOConfig().environment("CartPole-v1")
            .env_runners(num_env_runners=runners)
            .training(lr=0.0003, num_epochs=6, vf_loss_coeff=0.01)
            .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[32], fcnet_activation="linear",
                                                       vf_share_layers=True))
            .debugging(seed=seed))


def tuned_pendulum_config(seed: int, runners: int):
    """RLlib's tuned Pendulum PPO (``pendulum_ppo.py``'s settings: 2 env runners x 20 envs, observations through
    RLlib's ``MeanStdFilter``, 1024 env steps per ``train()``, minibatches of 128, relu [256, 256])."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.connectors.env_to_module import MeanStdFilter
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    return (PPOConfig().environment("Pendulum-v1")
            .env_runners(num_env_runners=runners, num_envs_per_env_runner=20,
                         env_to_module_connector=lambda env, spaces, device: MeanStdFilter())
            .training(train_batch_size_per_learner=1024, minibatch_size=128, lr=0.0002, gamma=0.95, lambda_=0.5)
            .rl_module(model_config=DefaultModelConfig(fcnet_activation="relu"))
            .debugging(seed=seed))


@dataclass(frozen=True)
class Example:
    """One of RLlib's tuned examples: its config and its own stop criteria."""

    config: Callable[[int, int], Any]
    stop_reward: float
    max_steps: int  # the example's --stop-timesteps (CartPole's: far beyond what it needs)


EXAMPLES = {"cartpole": Example(tuned_cartpole_config, STOP_REWARD, MAX_STEPS),
            "pendulum": Example(tuned_pendulum_config, -300.0, 400_000)}


def worker(example: str, seed: int, runners: int, max_steps: int | None) -> None:
    spec = EXAMPLES[example]
    max_steps = spec.max_steps if max_steps is None else max_steps
    algo = spec.config(seed, runners).build_algo()
    seconds, steps, ret = 0.0, 0, float("nan")
    while steps < max_steps:
        start = time.perf_counter()
        result = algo.train()
        seconds += time.perf_counter() - start
        runners = result.get("env_runners") or {}
        steps = int(runners.get("num_env_steps_sampled_lifetime") or result.get("num_env_steps_sampled_lifetime")
                    or steps + int(runners.get("num_env_steps_sampled") or 0))
        ret = float(runners.get("episode_return_mean", result.get("episode_return_mean", float("nan"))))
        if ret >= spec.stop_reward:
            break
    algo.stop()
    lib = "rlchain" if type(algo).__module__.startswith("rlchain") else "rllib"
    print(json.dumps({"lib": lib, "example": example, "seed": seed, "seconds": round(seconds, 1),
                      "env_steps": steps, "return": round(ret, 1), "reached": ret >= spec.stop_reward}), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worker", action="store_true", help="run the RLlib script itself (one side, one seed)")
    parser.add_argument("--example", choices=sorted(EXAMPLES), default="cartpole", help="which tuned example")
    parser.add_argument("--sides", nargs="+", choices=("rllib", "rlchain"), default=["rllib", "rlchain"],
                        help="which sides to run (both, one after the other, by default)")
    parser.add_argument("--rllib-python", default="/work/peers/rllib/bin/python",
                        help="the Python of a venv with ray[rllib]==2.60.0")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--num-env-runners", type=int, default=2)
    parser.add_argument("--face-threads", type=int, default=1,
                        help="OMP_NUM_THREADS of the face's process (RLlib's side keeps torch's default)")
    parser.add_argument("--max-steps", type=int, default=None,
                        help="give up after this many env steps (default: the example's own)")
    args = parser.parse_args()
    if args.worker:
        worker(args.example, args.seed, args.num_env_runners, args.max_steps)
        return
    spec = EXAMPLES[args.example]
    max_steps = spec.max_steps if args.max_steps is None else args.max_steps
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    here = os.path.abspath(__file__)
    rows = []
    for seed in args.seeds:
        common = [here, "--worker", "--example", args.example, "--seed", str(seed), "--num-env-runners",
                  str(args.num_env_runners), "--max-steps", str(max_steps)]
        sides = {"rllib": ([args.rllib_python, *common], {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}),
                 "rlchain": ([sys.executable, "-m", "rlchain.rllib", *common],
                             {**os.environ, "PYTHONPATH": root, "OMP_NUM_THREADS": str(args.face_threads)})}
        for lib, (cmd, env) in ((lib, sides[lib]) for lib in args.sides):
            out = subprocess.run(cmd, env=env, capture_output=True, text=True)
            lines = [line for line in out.stdout.splitlines() if line.startswith("{")]
            if out.returncode or not lines:
                print(f"{lib} seed {seed}: failed (exit {out.returncode}): {out.stderr.strip()[-500:]}", flush=True)
                continue
            row = json.loads(lines[-1])
            rows.append(row)
            print(json.dumps(row), flush=True)
    for lib in ("rllib", "rlchain"):
        ran = [r for r in rows if r["lib"] == lib]
        mine = [r for r in ran if r["reached"]]  # a seed that gave up at --max-steps has no time to the reward
        if mine:
            print(f"{lib}: median {statistics.median(r['seconds'] for r in mine):.1f} s, "
                  f"{statistics.median(r['env_steps'] for r in mine):.0f} env steps to {spec.stop_reward:.0f} "
                  f"({len(mine)} of {len(ran)} seeds reached it)", flush=True)
        elif ran:
            print(f"{lib}: no seed reached {spec.stop_reward:.0f} within {max_steps} env steps", flush=True)
    load = os.getloadavg()[0]
    print(f"load average at the end: {load:.2f} (figures under load are not a speed result)", flush=True)


if __name__ == "__main__":
    main()
