"""rl_games' asymmetric actor-critic test env ``TestAsymmetricEnv-v0``: the actor sees less than the critic.

Wraps a gymnasium env (``wrapped_env_name``, default ``CartPole-v1``). Its contract:

- ``use_central_value = True`` (attribute; also the ``use_central_value`` kwarg, default True);
- observations are ``{'obs': partial, 'state': full}``: ``state`` is the wrapped env's observation
  and ``obs`` the same vector with its velocity entries zeroed (``apply_mask``, default True;
  same shape, as rl_games' MaskVelocityWrapper does) -- the actor gets ``obs``, a central value
  network gets ``state``;
- ``observation_space`` is ``Dict({'obs': Box, 'state': Box})`` (float32) and ``state_space``
  the ``state`` Box; actions, rewards, ``terminated`` / ``truncated`` (the wrapped env's own time
  limit) pass through unchanged;
- with ``use_central_value: False`` the observation is the masked Box alone.

Masks exist for CartPole, Pendulum, Acrobot, MountainCar and LunarLander (Box2D); rl_games' old
ids (``Pendulum-v0``, ``LunarLander-v2``, ``LunarLanderContinuous-v2``) are mapped to gymnasium's.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

VELOCITY_MASKS = {  # 1 = kept, 0 = a velocity, zeroed in 'obs'
    "CartPole": [1, 0, 1, 0],
    "Pendulum": [1, 1, 0],
    "Acrobot": [1, 1, 1, 1, 0, 0],
    "MountainCar": [1, 0],
    "LunarLander": [1, 1, 0, 0, 1, 0, 1, 1],
}
OLD_IDS = {"Pendulum-v0": ("Pendulum-v1", {}), "LunarLander-v2": ("LunarLander-v3", {}),
           "LunarLanderContinuous-v2": ("LunarLander-v3", {"continuous": True})}


def velocity_mask(env_id: str) -> np.ndarray:
    """The 0/1 mask of ``env_id``'s observation (0 on velocities); ValueError for unknown envs."""
    for prefix, mask in VELOCITY_MASKS.items():
        if env_id.startswith(prefix):
            return np.asarray(mask, dtype=np.float32)
    raise ValueError(f"no velocity mask for '{env_id}' (supported: {', '.join(VELOCITY_MASKS)}); "
                     f"use apply_mask: False")


class TestAsymmetricCritic(gym.Env):
    """See the module docstring; ``env_kwargs`` go to ``gym.make(wrapped_env_name)``."""

    __test__ = False  # not a pytest test class

    def __init__(self, wrapped_env_name: str = "CartPole-v1", apply_mask: bool = True,
                 use_central_value: bool = True, render_mode: str | None = None, **env_kwargs: Any) -> None:
        name, extra = OLD_IDS.get(wrapped_env_name, (wrapped_env_name, {}))
        mask = velocity_mask(name) if apply_mask else None
        self.env = gym.make(name, render_mode=render_mode, **extra, **env_kwargs)
        self.render_mode = render_mode
        self.use_central_value = bool(use_central_value)
        inner = self.env.observation_space
        self.mask = mask if mask is not None else np.ones(inner.shape, dtype=np.float32)
        self.state_space = gym.spaces.Box(inner.low.astype(np.float32), inner.high.astype(np.float32),
                                          inner.shape, np.float32)
        obs_space = gym.spaces.Box(self.state_space.low, self.state_space.high, inner.shape, np.float32)
        self.observation_space = gym.spaces.Dict({"obs": obs_space, "state": self.state_space}) \
            if self.use_central_value else obs_space
        self.action_space = self.env.action_space

    def has_action_mask(self) -> bool:
        return False

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        obs, info = self.env.reset(seed=seed, options=options)
        return self._observe(obs), info

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self._observe(obs), reward, terminated, truncated, info

    def _observe(self, obs: np.ndarray) -> Any:
        state = np.asarray(obs, dtype=np.float32)
        partial = state * self.mask
        return {"obs": partial, "state": state} if self.use_central_value else partial

    def render(self) -> Any:
        return self.env.render()

    def close(self) -> None:
        self.env.close()
