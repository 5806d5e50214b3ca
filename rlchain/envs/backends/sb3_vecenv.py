"""A Stable-Baselines3 ``VecEnv`` (DummyVecEnv, SubprocVecEnv, VecNormalize and the other wrappers,
``make_vec_env``'s output) as an rlchain VecEnv.

SB3's vec envs already reset an env in the step that ends its episode: ``obs`` is the next episode's
first observation and ``infos[i]['terminal_observation']`` the ended one's last (rlchain's ``final_obs``);
``infos[i]['TimeLimit.truncated']`` marks a time-out, so ``truncated`` is that and ``terminated`` the other
dones. Box actions are clipped to the action space before the step, as SB3's algorithms clip them. The
caller's object is stepped as it is: a ``VecNormalize`` in the stack normalizes observations and
rewards and updates its statistics while ``training`` is True, exactly as under SB3 (its ``save`` writes them
as SB3 does); the episode statistics then count the unnormalized rewards (``get_original_reward``, this
contract's ``game_reward``). The object is borrowed: ``close`` leaves it open for its owner.

No import of stable_baselines3 here: the object is recognised by its class's module (SB3 is optional).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.envs.vecenv import StepResult
from rlchain.envs.wrappers.spaces import (
    cast_actions,
    cast_obs,
    flatten_dict_obs,
    float32_action_space,
    float32_obs_space,
)

SB3_VEC_ENV_MODULE = "stable_baselines3.common.vec_env"


def is_sb3_vecenv(env: Any) -> bool:
    """Whether ``env`` is a Stable-Baselines3 ``VecEnv`` (any class in its MRO from SB3's vec_env package)."""
    return any(getattr(c, "__module__", "").startswith(SB3_VEC_ENV_MODULE) and c.__name__ == "VecEnv"
               for c in type(env).__mro__)


def vec_normalize_of(env: Any) -> Any:
    """The ``VecNormalize`` in an SB3 vec env stack (the outermost one), or None."""
    while env is not None:
        if any(c.__name__ == "VecNormalize" and c.__module__.startswith(SB3_VEC_ENV_MODULE)
               for c in type(env).__mro__):
            return env
        env = getattr(env, "venv", None)
    return None


def sb3_env_id(env: Any) -> str:
    """A readable name of the envs inside an SB3 vec env: the first sub-env's gymnasium id, else its class."""
    inner = env
    while getattr(inner, "venv", None) is not None:
        inner = inner.venv
    first = (getattr(inner, "envs", None) or [None])[0]
    spec = getattr(first, "spec", None)
    return getattr(spec, "id", None) or type(inner).__name__


class SB3VecEnv:
    """rlchain's VecEnv contract (:mod:`rlchain.envs.vecenv`) over a Stable-Baselines3 vec env ``venv``.

    ``infos`` of each step is ``{'sb3_infos': [dict, ...]}``: SB3's own per-env info dicts, which SB3-style
    callbacks read as ``self.locals['infos']``.
    """

    def __init__(self, venv: Any, seed: int | None = None) -> None:
        self.venv = venv
        self.num_envs = int(venv.num_envs)
        self._env_action_space = venv.action_space
        self._dict_space = venv.observation_space if isinstance(venv.observation_space, gym.spaces.Dict) else None
        self.observation_space = float32_obs_space(venv.observation_space)
        self.action_space = float32_action_space(venv.action_space)
        self._normalize = vec_normalize_of(venv)
        self._seed = seed
        space = venv.action_space
        self._bounds = (space.low, space.high) if isinstance(space, gym.spaces.Box) else None

    def _obs(self, obs: Any) -> np.ndarray:
        if self._dict_space is not None:
            obs = flatten_dict_obs(obs, self._dict_space)
        return cast_obs(obs)

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset every env; with a seed (or the constructor's, on the first reset) env i gets ``seed + i``,
        as SB3's ``VecEnv.seed`` gives them."""
        if seed is None:
            seed, self._seed = self._seed, None
        if seed is not None:
            self.venv.seed(int(seed))
        return self._obs(self.venv.reset())

    def step(self, actions: np.ndarray) -> StepResult:
        """Step every env (SB3 resets finished ones in the same step); see the module docstring."""
        actions = cast_actions(actions, self._env_action_space, self.num_envs)
        if self._bounds is not None:  # SB3's algorithms clip Box actions to the space before stepping
            actions = np.clip(actions, *self._bounds)
        obs, reward, dones, infos = self.venv.step(actions)
        obs = self._obs(obs)
        if not obs.flags.writeable:
            obs = obs.copy()
        dones = np.asarray(dones, dtype=bool).reshape(self.num_envs)
        truncated = np.zeros(self.num_envs, dtype=bool)
        final_obs = obs
        if dones.any():
            final_obs = obs.copy()
            for i in np.flatnonzero(dones):
                info = infos[i]
                truncated[i] = bool(info.get("TimeLimit.truncated", False))
                last = info.get("terminal_observation")
                if last is not None:
                    final_obs[i] = self._obs(_batch_of_one(last))[0]
        game_reward = None
        if self._normalize is not None and getattr(self._normalize, "norm_reward", False):
            game_reward = np.asarray(self._normalize.get_original_reward(), dtype=np.float32).reshape(self.num_envs)
        return StepResult(obs, np.asarray(reward, dtype=np.float32).reshape(self.num_envs), dones & ~truncated,
                          truncated, final_obs, {"sb3_infos": list(infos)}, game_reward=game_reward,
                          game_over=dones if game_reward is not None else None)

    def render(self) -> Any:
        """The vec env's ``render()``."""
        return self.venv.render()

    def close(self) -> None:
        """Nothing: the SB3 vec env stays its owner's (see the module docstring)."""


def _batch_of_one(obs: Any) -> Any:
    """One env's observation (an array, or a dict of arrays) as a batch of one."""
    if isinstance(obs, dict):
        return {k: np.asarray(v)[None] for k, v in obs.items()}
    return np.asarray(obs)[None]
