"""MuJoCoPushCube-v0: how often zero actions, random actions, a scripted pusher and a checkpoint pass
EmbodiChain's success test (cube-to-goal planar distance under 0.1 m, which ends the episode).

    python benchmarks/studies/mujoco_push_eval.py [--checkpoint nn/mujoco_push_cube.pth] [--episodes 512]

The env takes the shipped config's ``learning_env.cfg`` (rlchain/configs/push_cube/mujoco_push_cube.json).
The scripted pusher goes to the point behind the cube (away from the goal) and then pushes toward the goal:
what the task allows in its 100 decisions. A checkpoint plays its mean action, as the config's evaluation.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain first
    sys.path.insert(0, ROOT)
CONFIG = os.path.join(ROOT, "rlchain", "configs", "push_cube", "mujoco_push_cube.json")


def scripted(env) -> torch.Tensor:
    """Go behind the cube (0.1 m past its face, away from the goal), then push toward the goal."""
    from rlchain.envs.backends.mujoco_push import HALF, RADIUS

    ee, _, cube, _, _ = env._parts()
    to_goal = env.goal - cube
    u = to_goal / np.maximum(np.linalg.norm(to_goal, axis=1, keepdims=True), 1e-6)
    rel = cube - u * (HALF + RADIUS + 0.03) - ee
    far = np.linalg.norm(rel, axis=1, keepdims=True) > 0.03
    return torch.as_tensor(np.clip(np.where(far, 20 * rel, u), -1, 1), dtype=torch.float32)


def play(env, act, episodes: int) -> dict[str, float]:
    """Play until ``episodes`` episodes end: success rate, mean length, final cube-to-goal distance."""
    obs, _ = env.reset(seed=12345)
    done = successes = 0
    lengths, distances = [], []
    from rlchain.envs.backends.embodichain_env import flatten_obs

    while done < episodes:
        obs, _, terminated, truncated, info = env.step(act(flatten_obs(obs)))
        ended = (terminated | truncated).numpy()
        done += int(ended.sum())
        successes += int(info["success"].numpy()[ended].sum())
        lengths += info["elapsed_steps"].numpy()[ended].tolist()
        distances += info["metrics"]["distance_to_goal"].numpy()[ended].tolist()
    return {"success": successes / done, "episodes": done, "length": float(np.mean(lengths)),
            "final_distance": float(np.mean(distances))}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--checkpoint", default=None)
    p.add_argument("--config", default=CONFIG)
    p.add_argument("--episodes", type=int, default=512)
    p.add_argument("--envs", type=int, default=64)
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    from rlchain.envs.backends.mujoco_push import MuJoCoPushCube

    with open(args.config) as f:
        cfg = json.load(f)["trainer"]["learning_env"]["cfg"]
    env = MuJoCoPushCube(args.envs, **cfg)
    zero = torch.zeros(args.envs, 2)
    policies = {"zero actions": lambda obs: zero,
                "uniformly random actions": lambda obs: torch.rand(args.envs, 2) * 2 - 1,
                "scripted pusher": lambda obs: scripted(env)}
    if args.checkpoint:
        from rlchain.builtins import register_builtins
        from rlchain.config.load import load_config
        from rlchain.policy.load import load_policy

        register_builtins()
        loaded = load_policy(load_config(args.config, []), args.checkpoint)
        loaded.close()  # the env here plays; the model only acts

        def mean_action(obs: torch.Tensor) -> torch.Tensor:
            with torch.no_grad():
                return loaded.model.act(obs, deterministic=True)["actions"]

        policies["checkpoint (mean action)"] = mean_action
    print("| policy | success rate | episodes | mean length | cube-to-goal distance at the end |")
    print("|---|---|---|---|---|")
    for name, act in policies.items():
        r = play(env, act, args.episodes)
        print(f"| {name} | {r['success']:.3f} | {r['episodes']} | {r['length']:.1f} | {r['final_distance']:.3f} m |")


if __name__ == "__main__":
    main()
