"""The same SB3-shaped script under rlchain and under Stable-Baselines3: seconds and evaluated return.

    python benchmarks/peers/sb3_api_side_by_side.py --lib rlchain --setting defaults --seed 0
    /path/to/sb3-venv/bin/python benchmarks/peers/sb3_api_side_by_side.py --lib sb3 --setting zoo --seed 0

``--setting defaults``: ``PPO("MlpPolicy", "CartPole-v1").learn(50_000)`` as written: SB3's defaults on both
sides (rlchain's SB3-style classes default to them). ``--setting zoo``: both given rl-baselines3-zoo's
CartPole-v1 hyperparameters (8 envs, constant learning rate and clip range). ``--setting best``: each library at
its best on this task, the setting named: rlchain with ``defaults="rlchain"`` (its packaged CartPole settings),
SB3 with the zoo's hyperparameters.
One JSON line: library, setting, seed, training seconds (the ``learn`` call), and the mean deterministic
return over 10 evaluation episodes (seeds 1000..1009).
Only public API of either library is called.
"""

import argparse
import json
import time

import gymnasium as gym
import numpy as np
import torch

ZOO = dict(n_steps=32, batch_size=256, gae_lambda=0.8, gamma=0.98, n_epochs=20, ent_coef=0.0,
           learning_rate=0.001, clip_range=0.2,  # rl-baselines3-zoo hyperparams/ppo.yml CartPole-v1, 8 envs
           vf_coef=0.5, max_grad_norm=0.5, clip_range_vf=None)  # SB3's defaults, written out


def evaluate(model, episodes=10):
    env = gym.make("CartPole-v1")
    returns = []
    for episode in range(episodes):
        obs, _ = env.reset(seed=1000 + episode)
        total, done = 0.0, False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(int(action))
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
    return float(np.mean(returns))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lib", choices=("rlchain", "sb3"), required=True)
    parser.add_argument("--setting", choices=("defaults", "zoo", "best"), default="defaults")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timesteps", type=int, default=50_000)
    parser.add_argument("--threads", type=int, default=1, help="torch threads (both libraries)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    if args.lib == "rlchain":
        import rlchain
        PPO, extra = rlchain.PPO, {"verbose": 0, "tensorboard_log": "/tmp/sb3_side_by_side_runs"}
        env = "CartPole-v1"
        if args.setting == "zoo":
            extra.update(n_envs=8)
        elif args.setting == "best":
            extra.update(defaults="rlchain")
    else:
        from stable_baselines3 import PPO
        from stable_baselines3.common.env_util import make_vec_env
        extra = {"verbose": 0}
        zoo = args.setting in ("zoo", "best")
        env = make_vec_env("CartPole-v1", n_envs=8, seed=args.seed) if zoo else "CartPole-v1"
    hyper = ZOO if args.setting == "zoo" or (args.setting == "best" and args.lib == "sb3") else {}
    model = PPO("MlpPolicy", env, seed=args.seed, **hyper, **extra)
    start = time.perf_counter()
    model.learn(total_timesteps=args.timesteps)
    seconds = time.perf_counter() - start
    print(json.dumps({"lib": args.lib, "setting": args.setting, "seed": args.seed, "timesteps": args.timesteps,
                      "seconds": round(seconds, 2), "eval_return": evaluate(model)}), flush=True)


if __name__ == "__main__":
    main()
