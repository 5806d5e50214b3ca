"""rl_games' ``common.wrappers`` that user code applies to single gymnasium envs: ``DiscretizeActions``,
``MaskVelocityWrapper``, ``ClipRewardEnv``, ``ScaledFloatFrame``. (rl_games' Atari preprocessing is rlchain's
``env_name: atari_gymnasium``; see docs/environments.md.)"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np


class WrapperError(ValueError, AssertionError):
    """A wrapper cannot take this env (an AssertionError too: rl_games asserts here)."""


class DiscretizeActions(gym.ActionWrapper):
    """A 1-d Box action space as a Tuple of Discrete(bins) heads over a uniform grid per dimension (``bins`` an
    int for every dimension or one per dimension); the env receives the grid values in the Box's dtype."""

    def __init__(self, env: gym.Env, bins: int | list[int] = 11) -> None:
        super().__init__(env)
        box = env.action_space
        if not isinstance(box, gym.spaces.Box) or len(box.shape) != 1:
            raise WrapperError(f"DiscretizeActions needs a 1-d Box action space, got {box}")
        if not (np.isfinite(box.low).all() and np.isfinite(box.high).all()):
            raise WrapperError("DiscretizeActions needs finite Box bounds (its grid spans low..high)")
        dims = box.shape[0]
        self._bins = [int(bins)] * dims if np.isscalar(bins) else [int(b) for b in bins]
        if len(self._bins) != dims:
            raise WrapperError(f"DiscretizeActions: {len(self._bins)} bin counts for {dims} action dimensions")
        self._dtype = box.dtype
        self._grids = [np.linspace(box.low[i], box.high[i], n) for i, n in enumerate(self._bins)]
        self.action_space = gym.spaces.Tuple([gym.spaces.Discrete(n) for n in self._bins])

    def action(self, action: Any) -> np.ndarray:
        index = np.asarray(action, dtype=np.int64).reshape(-1)
        return np.array([grid[i] for grid, i in zip(self._grids, index)], dtype=self._dtype)


VELOCITY_MASKS = {
    "CartPole-v1": [1.0, 0.0, 1.0, 0.0],
    "Pendulum-v0": [1.0, 1.0, 0.0],
    "Pendulum-v1": [1.0, 1.0, 0.0],
    "LunarLander-v2": [1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0],
    "LunarLanderContinuous-v2": [1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0],
}
"""Per env id: 1 keeps an observation entry, 0 zeroes it (the velocities), as rl_games masks them."""


class MaskVelocityWrapper(gym.ObservationWrapper):
    """Zeroes the velocity entries of the observation (a partially observed MDP); the shape is unchanged."""

    def __init__(self, env: gym.Env, name: str) -> None:
        super().__init__(env)
        if name not in VELOCITY_MASKS:
            raise WrapperError(f"MaskVelocityWrapper: no velocity mask for {name!r} (known: "
                               f"{', '.join(VELOCITY_MASKS)})")
        self.mask = np.asarray(VELOCITY_MASKS[name], dtype=np.float32)

    def observation(self, observation: Any) -> np.ndarray:
        return (observation * self.mask).astype(np.float32)


class ClipRewardEnv(gym.RewardWrapper):
    """Rewards as their sign (-1, 0, 1)."""

    def reward(self, reward: float) -> float:
        return float(np.sign(reward))


class ScaledFloatFrame(gym.ObservationWrapper):
    """uint8 frames as float32 in [0, 1]."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        space = env.observation_space
        self.observation_space = gym.spaces.Box(0.0, 1.0, space.shape, np.float32)

    def observation(self, observation: Any) -> np.ndarray:
        return np.asarray(observation, dtype=np.float32) / 255.0


__all__ = ["DiscretizeActions", "MaskVelocityWrapper", "ClipRewardEnv", "ScaledFloatFrame", "VELOCITY_MASKS"]
