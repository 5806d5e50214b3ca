"""MuJoCoPushCube-v0: how often zero actions, random actions, a scripted pusher and a checkpoint pass
EmbodiChain's success test (cube-to-goal planar distance under 0.1 m, which ends the episode).

    python benchmarks/studies/mujoco_push_eval.py [--checkpoint nn/push_cube_mujoco.pth] [--episodes 512]

Each policy plays one episode on each of ``--episodes`` envs (see :func:`play` for why only the first).

The env takes the shipped config's ``learning_env.cfg`` (rlchain/configs/embodichain/push_cube_ppo.json).
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
CONFIG = os.path.join(ROOT, "rlchain", "configs", "embodichain", "push_cube_ppo.json")


def scripted(env) -> torch.Tensor:
    """Go behind the cube (0.1 m past its face, away from the goal), then push toward the goal."""
    from rlchain.envs.backends.mujoco_push import HALF, RADIUS

    ee, _, cube, _, _ = env._parts()
    to_goal = env.goal - cube
    u = to_goal / np.maximum(np.linalg.norm(to_goal, axis=1, keepdims=True), 1e-6)
    rel = cube - u * (HALF + RADIUS + 0.03) - ee
    far = np.linalg.norm(rel, axis=1, keepdims=True) > 0.03
    return torch.as_tensor(np.clip(np.where(far, 20 * rel, u), -1, 1), dtype=torch.float32)


def play(env, act) -> dict[str, float]:
    """One episode on each env (its first): success rate, mean length, cube-to-goal distance at the end.

    Only each env's first episode counts: counting the first N episodes to end over all envs (EmbodiChain's
    evaluation, and rlchain's with several envs) over-weights short ones, and here those are the successes.
    """
    from rlchain.envs.backends.embodichain_env import flatten_obs

    obs, _ = env.reset(seed=12345)
    n = env.num_envs
    over = np.zeros(n, dtype=bool)
    success, lengths, distances = np.zeros(n, dtype=bool), np.zeros(n), np.zeros(n)
    while not over.all():
        obs, _, terminated, truncated, info = env.step(act(flatten_obs(obs)))
        first = (terminated | truncated).numpy() & ~over
        success[first] = info["success"].numpy()[first]
        lengths[first] = info["elapsed_steps"].numpy()[first]
        distances[first] = info["metrics"]["distance_to_goal"].numpy()[first]
        over |= first
    return {"success": float(success.mean()), "episodes": n, "length": float(lengths.mean()),
            "final_distance": float(distances.mean())}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--checkpoint", default=None)
    p.add_argument("--config", default=CONFIG)
    p.add_argument("--episodes", type=int, default=512, help="one on each of this many envs")
    p.add_argument("--min-start-distance", type=float, default=None,
                   help="override the config's (0: EmbodiChain's own starts, some already within 0.1 m)")
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    from rlchain.envs.backends.mujoco_push import MuJoCoPushCube

    with open(args.config) as f:
        cfg = json.load(f)["trainer"]["learning_env"]["cfg"]
    if args.min_start_distance is not None:
        cfg["min_start_distance"] = args.min_start_distance
    env = MuJoCoPushCube(args.episodes, **cfg)
    zero = torch.zeros(args.episodes, 2)
    policies = {"zero actions": lambda obs: zero,
                "uniformly random actions": lambda obs: torch.rand(args.episodes, 2) * 2 - 1,
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
        r = play(env, act)
        print(f"| {name} | {r['success']:.3f} | {r['episodes']} | {r['length']:.1f} | {r['final_distance']:.3f} m |")


if __name__ == "__main__":
    main()
