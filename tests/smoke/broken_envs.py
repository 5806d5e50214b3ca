"""Deliberately broken environments for the robustness tests, registered the rl_games way."""

import gymnasium as gym
import numpy as np

from rlchain import env_configurations


class NanRewardCartPole(gym.Wrapper):
    """CartPole whose reward turns NaN at step ``nan_at`` of env 1."""

    def __init__(self, env, nan_at=10):
        super().__init__(env)
        self.nan_at, self.t = nan_at, 0

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.t += 1
        return obs, (float("nan") if self.t == self.nan_at else reward), terminated, truncated, info


class RaisingCartPole(gym.Wrapper):
    """CartPole that raises at step ``raise_at``."""

    def __init__(self, env, raise_at=7):
        super().__init__(env)
        self.raise_at, self.t = raise_at, 0

    def step(self, action):
        self.t += 1
        if self.t == self.raise_at:
            raise ValueError("simulator exploded")
        return self.env.step(action)


class WrongShapeCartPole(gym.Wrapper):
    """Declares CartPole's 4-dim observation space but returns 3 numbers."""

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        return obs[:3], info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        return obs[:3].astype(np.float32), reward, terminated, truncated, info


for name, wrapper in (("NanRewardCartPole-test", NanRewardCartPole), ("RaisingCartPole-test", RaisingCartPole),
                      ("WrongShapeCartPole-test", WrongShapeCartPole)):
    if name not in gym.registry:
        env_configurations.register(name, {"env_creator": lambda w=wrapper, **kw: w(gym.make("CartPole-v1"), **kw)})
