"""Writes the small Stable-Baselines3 models the tests load (run with stable-baselines3 installed, from the
repository root: ``python tests/data/sb3/make_sb3_models.py``), and ``expected.json``: SB3's deterministic actions
for seeded observations and its evaluated return per seed, which rlchain must reproduce from the files alone."""

import json
import os

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import DQN, PPO, SAC

HERE = os.path.dirname(os.path.abspath(__file__))
MODELS = {
    "ppo_cartpole": (PPO, "CartPole-v1", {"n_steps": 256, "batch_size": 64, "policy_kwargs": {"net_arch": [16, 16]}},
                     4096),
    "ppo_pendulum": (PPO, "Pendulum-v1", {"n_steps": 128, "batch_size": 64, "policy_kwargs": {"net_arch": [16]}},
                     256),
    "sac_pendulum": (SAC, "Pendulum-v1", {"learning_starts": 100, "batch_size": 32, "buffer_size": 1000,
                                          "policy_kwargs": {"net_arch": [16, 16]}}, 300),
    "dqn_cartpole": (DQN, "CartPole-v1", {"learning_starts": 100, "batch_size": 32, "buffer_size": 1000,
                                          "policy_kwargs": {"net_arch": [16]}}, 300),
}


def episode_return(model, env_id, seed):
    env = gym.make(env_id)
    obs, _ = env.reset(seed=seed)
    total, done = 0.0, False
    while not done:
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, _ = env.step(action)
        total, done = total + float(reward), terminated or truncated
    return total


def main():
    torch.manual_seed(0)
    expected = {}
    for name, (cls, env_id, kwargs, steps) in MODELS.items():
        model = cls("MlpPolicy", env_id, seed=0, **kwargs)
        model.learn(steps)
        model.save(os.path.join(HERE, name))
        env = gym.make(env_id)
        obs = np.stack([env.reset(seed=s)[0] for s in range(8)])
        actions, _ = model.predict(obs, deterministic=True)
        expected[name] = {"env_id": env_id, "obs": obs.tolist(), "actions": np.asarray(actions).tolist(),
                          "returns": {str(s): episode_return(model, env_id, s) for s in (1, 2, 3)}}
    with open(os.path.join(HERE, "expected.json"), "w") as f:
        json.dump(expected, f, indent=1)


if __name__ == "__main__":
    main()
