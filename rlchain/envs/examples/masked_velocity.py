"""CartPole without velocities (rl_games' ``CartPoleMaskedVelocity-v1``): a memory task.

The cart and pole velocities are zeroed (the observation keeps CartPole's four entries, as rl_games masks
them, so its checkpoints load), so a policy must infer both velocities from past observations: an RNN solves
it, a feedforward policy on the same config cannot.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

VELOCITY_MASK = np.array([1.0, 0.0, 1.0, 0.0], dtype=np.float32)
"""1 keeps an entry (cart position, pole angle), 0 zeroes it (the two velocities)."""


class MaskVelocity(gym.ObservationWrapper):
    """CartPole's observation with entries 1 (cart velocity) and 3 (pole angular velocity) zeroed."""

    def observation(self, observation: np.ndarray) -> np.ndarray:
        return np.asarray(observation, dtype=np.float32) * VELOCITY_MASK


def make_cartpole_masked_velocity(**kwargs) -> gym.Env:
    """CartPole-v1 (500 steps) observed without velocities."""
    return MaskVelocity(gym.make("CartPole-v1", **kwargs))
