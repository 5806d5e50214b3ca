"""Push-cube (envpool ``PandaRobotiqPushCube-v1``): a checkpoint against a random policy and a still arm.

    python benchmarks/studies/push_cube_eval.py [--checkpoint nn/push_cube.pth] [--episodes 64] [--envs 16]

For each policy it plays ``--episodes`` episodes with the config's env settings
(``rlchain/configs/push_cube/train_config.json``) and prints the success rate (``info['success']``
at any step), mean episode length and return, and the cube-to-target distance: the env reports the
box-to-target reward term ``reward_box_target = box_target_scale * tol(d)`` with MuJoCo Playground's
``tolerance(d, bounds=(0, 0.005), margin=0.4, sigmoid='reciprocal')`` (value 0.1 at the margin),
i.e. ``tol = 1 / (1 + 9 (d - 0.005) / 0.4)``, which this inverts to the planar distance d in metres.
Reported: d at each episode's last step and its minimum over the episode, averaged over episodes, and
``success_0.1m``: the fraction of episodes whose d went under 0.1 m (EmbodiChain's push_cube success test).
The checkpoint plays its mean action (``checkpoint``) and, as in training, sampled actions
(``sampled``). The references: uniformly random actions, and zero actions (with gravity compensation the arm holds
still, so the cube stays where it started: the distance a policy must beat to have pushed at all).
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)
CONFIG = os.path.join(ROOT, "rlchain", "configs", "push_cube", "train_config.json")


def box_target_distance(term: np.ndarray, scale: float = 8.0) -> np.ndarray:
    """Planar cube-to-target distance (m) from the env's ``reward_box_target`` term (see the module docstring)."""
    tol = np.clip(np.asarray(term, np.float64) / scale, 1e-6, 1.0)
    return np.where(tol >= 1.0, 0.0, 0.005 + 0.4 * (1.0 / tol - 1.0) / 9.0)


def play(env, act, episodes: int, scale: float = 8.0) -> dict[str, float]:
    """Play ``episodes`` episodes with ``act(obs) -> actions``; the statistics of the module docstring.
    ``scale``: the env's ``box_target_scale`` (the config's ``env_config`` may change it from 8)."""
    n = env.num_envs
    obs = env.reset(seed=123)
    ret, length, hit = np.zeros(n), np.zeros(n), np.zeros(n, bool)
    dmin = np.full(n, np.inf)
    rows: list[tuple[float, float, float, float, float]] = []
    while len(rows) < episodes:
        result = env.step(act(obs))
        infos = result.infos
        d = box_target_distance(infos["reward_box_target"], scale)
        ret += result.reward
        length += 1
        hit |= np.asarray(infos["success"]) > 0.5
        dmin = np.minimum(dmin, d)
        for i in np.flatnonzero(result.terminated | result.truncated):
            rows.append((float(hit[i]), length[i], ret[i], d[i], dmin[i]))
            ret[i], length[i], hit[i], dmin[i] = 0.0, 0.0, False, np.inf
        obs = result.obs
    r = np.array(rows[:episodes])
    return {"success": r[:, 0].mean(), "success_0.1m": (r[:, 4] < 0.1).mean(), "length": r[:, 1].mean(),
            "return": r[:, 2].mean(), "final_distance_m": r[:, 3].mean(), "min_distance_m": r[:, 4].mean(),
            "episodes": len(r)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint", default=os.path.join(ROOT, "nn", "push_cube.pth"))
    parser.add_argument("--episodes", type=int, default=64)
    parser.add_argument("--envs", type=int, default=16)
    parser.add_argument("--config", default=CONFIG)
    args = parser.parse_args()

    from rlchain.config.load import load_config
    from rlchain.models.build import build_env, build_model
    from rlchain.policy.stepper import PolicyStepper
    from rlchain.runs import checkpoint as ckpt

    torch.set_num_threads(1)
    params = load_config(args.config)
    env = build_env(params, args.envs, 123)
    rng = np.random.default_rng(0)
    shape = env.action_space.shape
    scale = float(params.config.env_config.get("box_target_scale", 8.0))
    results = {"random": play(env, lambda obs: rng.uniform(-1, 1, (args.envs, *shape)).astype(np.float32),
                              args.episodes, scale),
               "zero": play(env, lambda obs: np.zeros((args.envs, *shape), np.float32), args.episodes, scale)}
    if os.path.isfile(args.checkpoint):
        model = build_model(params, env, torch.device("cpu"))
        ckpt.load_model_state(model, ckpt.load(args.checkpoint, map_location="cpu"), args.checkpoint)
        model.eval()
        policy = PolicyStepper(model, args.envs, torch.device("cpu"))

        def policy_actions(deterministic: bool):
            def act(obs: np.ndarray) -> np.ndarray:
                with torch.no_grad():
                    return model.dist.to_env(policy.act(torch.as_tensor(obs), env, deterministic)).numpy()
            return act
        results["checkpoint"] = play(env, policy_actions(True), args.episodes, scale)  # the mean action
        results["sampled"] = play(env, policy_actions(False), args.episodes, scale)  # as in training
    env.close()
    for name, stats in results.items():
        print(f"{name:10s} " + " ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}"
                                        for k, v in stats.items()))


if __name__ == "__main__":
    main()
