"""CartPole without velocities (rl_games' ``CartPoleMaskedVelocity-v1``): a memory task.

Only cart position and pole angle are observed, so a policy must infer both velocities from
past observations: an RNN solves it, a feedforward policy on the same config cannot.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np


class MaskVelocity(gym.ObservationWrapper):
    """Keep observation entries 0 (cart position) and 2 (pole angle) of CartPole's four."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        low, high = env.observation_space.low, env.observation_space.high
        self.observation_space = gym.spaces.Box(low[[0, 2]], high[[0, 2]], dtype=np.float32)

    def observation(self, observation: np.ndarray) -> np.ndarray:
        return np.asarray(observation, dtype=np.float32)[[0, 2]]


def make_cartpole_masked_velocity(**kwargs) -> gym.Env:
    """CartPole-v1 (500 steps) observed without velocities."""
    return MaskVelocity(gym.make("CartPole-v1", **kwargs))
