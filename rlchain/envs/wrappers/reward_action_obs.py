"""The previous reward and action beside the observation: rl_games' ``use_dict_obs_space`` (envpool)
and ``wrap_impala`` (atari_gym), for the ``resnet_actor_critic`` network's ``require_rewards`` /
``require_last_actions``.

rl_games hands its network the Dict ``{'observation', 'reward', 'last_action'}``: the env's
observation, the reward of the step that led to it clipped to [-1, 1], and the action taken in that
step; both are 0 at the start of an episode (a reset, or the auto-reset after a lost life). Its
network scales uint8 images to [0, 1] and one-hot encodes the action.

:class:`RewardActionObs` wraps any numpy VecEnv with Discrete(n) actions and returns that Dict
flattened the gymnasium way, so storage, the Player, evaluation and ONNX export see one flat float32
vector per env (its space a :class:`~rlchain.envs.wrappers.dict_obs.FlatDictBox` that remembers the Dict):

    [last_action one-hot (n) | observation (uint8 images scaled to [0, 1]) | reward (1)]

A network splits it back by key (``observation_space.dict_space``). The cost: observations are
stored as float32, 4 bytes a pixel instead of 1.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.config.errors import ConfigError
from rlchain.envs.spec import env_spec
from rlchain.envs.vecenv import StepResult
from rlchain.envs.wrappers.dict_obs import FlatDictBox

KEYS = ("last_action", "observation", "reward")
"""The Dict's keys in layout order (gymnasium sorts Dict keys)."""


class RewardActionObs:
    """``env`` (a numpy VecEnv, Discrete actions) with observations (N, n + obs_size + 1) float32.

    ``path`` names the config key that asked for it, for the error on an unsuitable env. Pipelined
    stepping (``env_groups`` / ``send`` / ``recv``) and every other attribute pass through to ``env``.
    """

    def __init__(self, env: Any, path: str) -> None:
        space, actions = env.observation_space, env.action_space
        if env_spec(env).tensor_native:
            raise ConfigError("", path, "needs a numpy env (envpool, atari_gym), not a tensor env")
        if not isinstance(actions, gym.spaces.Discrete):
            raise ConfigError("", path, f"needs Discrete actions (the last action is one-hot), the env has {actions}")
        if not isinstance(space, gym.spaces.Box):
            raise ConfigError("", path, f"needs Box observations, the env has {space}")
        self.env = env
        self.num_envs = env.num_envs
        self.action_space = actions
        self._scale = 1.0 / 255.0 if space.dtype == np.uint8 else None
        image = gym.spaces.Box(0.0, 1.0, space.shape, np.float32) if self._scale else \
            gym.spaces.Box(space.low, space.high, space.shape, np.float32)
        self.dict_space = gym.spaces.Dict({"last_action": gym.spaces.Discrete(int(actions.n)),
                                           "observation": image,
                                           "reward": gym.spaces.Box(-1.0, 1.0, (), np.float32)})
        assert tuple(self.dict_space.spaces) == KEYS
        self.observation_space = FlatDictBox(self.dict_space, np.float32)
        n, size = int(actions.n), int(np.prod(space.shape))
        self._action, self._obs, self._reward = slice(0, n), slice(n, n + size), n + size
        self._start = int(actions.start)
        self._pending: dict[int, np.ndarray] = {}

    def __getattr__(self, name: str) -> Any:
        if name == "env":  # not set yet (during unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.env, name)

    def _flat(self, obs: np.ndarray, reward: np.ndarray, action: np.ndarray) -> np.ndarray:
        """(N, flat) from obs (N, *shape), clipped reward (N,) and action indices (N,)."""
        rows = len(obs)
        out = np.zeros((rows, self.observation_space.shape[0]), np.float32)
        image = np.asarray(obs).reshape(rows, -1)
        out[:, self._obs] = image * np.float32(self._scale) if self._scale else image
        out[:, self._reward] = reward
        out[np.arange(rows), action] = 1.0
        return out

    def _indices(self, actions: Any, rows: int) -> np.ndarray:
        if hasattr(actions, "detach"):
            actions = actions.detach().cpu().numpy()
        return np.asarray(actions).reshape(rows).astype(np.int64) - self._start

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset every env: obs (N, flat) with reward 0 and last action 0."""
        obs = np.asarray(self.env.reset(seed=seed))
        zeros = np.zeros(len(obs), np.int64)
        return self._flat(obs, np.zeros(len(obs), np.float32), zeros)

    def step(self, actions: np.ndarray) -> StepResult:
        """Step with actions (N,); obs and final_obs carry this step's clipped reward and action."""
        return self._augment(self.env.step(actions), actions)

    def send(self, group: int, actions: np.ndarray) -> None:
        """Start stepping env group ``group`` (see the VecEnv contract); the actions are kept for :meth:`recv`."""
        self._pending[group] = actions
        self.env.send(group, actions)

    def recv(self, group: int) -> StepResult:
        """Wait for group ``group``'s step; its rows' StepResult with the flat observations."""
        return self._augment(self.env.recv(group), self._pending.pop(group))

    def _augment(self, result: StepResult, actions: Any) -> StepResult:
        """The flat obs: rows that ended start their next episode (reward 0, action 0); their
        ``final_obs`` keeps the last obs with the reward and action that led to it."""
        obs = np.asarray(result.obs)
        rows = len(obs)
        action = self._indices(actions, rows)
        reward = np.clip(np.asarray(result.reward, np.float32).reshape(rows), -1.0, 1.0)
        flat = self._flat(obs, reward, action)
        done = np.asarray(result.terminated, bool) | np.asarray(result.truncated, bool)
        final = flat  # rows that did not end may hold anything (the VecEnv contract): no copy then
        if done.any():
            final = flat.copy()
            final[done] = self._flat(np.asarray(result.final_obs)[done], reward[done], action[done])
            flat[done, self._action] = 0.0
            flat[done, 0] = 1.0  # the one-hot of action index 0
            flat[done, self._reward] = 0.0
        result.obs, result.final_obs = flat, final
        return result

    def close(self) -> None:
        self.env.close()
