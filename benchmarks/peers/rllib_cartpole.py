"""RLlib's tuned CartPole PPO (``rllib/examples/algorithms/ppo/cartpole_ppo.py``'s settings) under real RLlib
and through rlchain's face, one after the other: seconds and env steps to the example's stop reward (450).

    python benchmarks/peers/rllib_cartpole.py --rllib-python /work/peers/rllib/bin/python --seeds 1 2 3

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


def worker(seed: int, runners: int, max_steps: int) -> None:
    algo = tuned_cartpole_config(seed, runners).build_algo()
    seconds, steps, ret = 0.0, 0, float("nan")
    while steps < max_steps:
        start = time.perf_counter()
        result = algo.train()
        seconds += time.perf_counter() - start
        runners = result.get("env_runners") or {}
        steps = int(runners.get("num_env_steps_sampled_lifetime") or result.get("num_env_steps_sampled_lifetime")
                    or steps + int(runners.get("num_env_steps_sampled") or 0))
        ret = float(runners.get("episode_return_mean", result.get("episode_return_mean", float("nan"))))
        if ret >= STOP_REWARD:
            break
    algo.stop()
    lib = "rlchain" if type(algo).__module__.startswith("rlchain") else "rllib"
    print(json.dumps({"lib": lib, "seed": seed, "seconds": round(seconds, 1), "env_steps": steps,
                      "return": round(ret, 1), "reached": ret >= STOP_REWARD}), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worker", action="store_true", help="run the RLlib script itself (one side, one seed)")
    parser.add_argument("--rllib-python", default="/work/peers/rllib/bin/python",
                        help="the Python of a venv with ray[rllib]==2.60.0")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--num-env-runners", type=int, default=2)
    parser.add_argument("--max-steps", type=int, default=MAX_STEPS, help="give up after this many env steps")
    args = parser.parse_args()
    if args.worker:
        worker(args.seed, args.num_env_runners, args.max_steps)
        return
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    here = os.path.abspath(__file__)
    rows = []
    for seed in args.seeds:
        common = [here, "--worker", "--seed", str(seed), "--num-env-runners", str(args.num_env_runners),
                  "--max-steps", str(args.max_steps)]
        sides = {"rllib": ([args.rllib_python, *common], {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}),
                 "rlchain": ([sys.executable, "-m", "rlchain.rllib", *common],
                             {**os.environ, "PYTHONPATH": root, "OMP_NUM_THREADS": "1"})}
        for lib, (cmd, env) in sides.items():
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
                  f"{statistics.median(r['env_steps'] for r in mine):.0f} env steps to {STOP_REWARD:.0f} "
                  f"({len(mine)} of {len(ran)} seeds reached it)", flush=True)
        elif ran:
            print(f"{lib}: no seed reached {STOP_REWARD:.0f} within --max-steps", flush=True)
    load = os.getloadavg()[0]
    print(f"load average at the end: {load:.2f} (figures under load are not a speed result)", flush=True)


if __name__ == "__main__":
    main()
