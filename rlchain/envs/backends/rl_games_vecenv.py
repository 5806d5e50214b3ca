"""A user-registered ``vecenv_type``: rl_games' creator and its IVecEnv, as an rlchain VecEnv.

rl_games (and Isaac Lab / IsaacGymEnvs through it) registers a vector env with
``vecenv.register(NAME, lambda config_name, num_actors, **kwargs: MyVecEnv(config_name, num_actors, **kwargs))``
and selects it with ``vecenv_type: NAME``. The creator gets ``env_name`` and ``num_actors`` and the
``env_config`` keys (plus ``seed`` / ``render`` when its signature names them) and returns either

- an rl_games IVecEnv: ``reset() -> obs``, ``step(actions) -> (obs, rewards, dones, infos)``,
  ``get_number_of_agents()``, ``get_env_info() -> {observation_space, action_space, state_space?,
  agents?, value_size?}``; :class:`IVecEnvAdapter` makes it a VecEnv (:mod:`rlchain.envs.vecenv`), or
- a VecEnv of rlchain's contract (``step`` returns a StepResult), used as it is.

What the adapter maps: ``dones`` split into ``terminated`` / ``truncated`` with ``infos['time_outs']``
(rl_games' key; absent: every done is a termination); observations ``{'obs', 'states'}`` (with a
``state_space``) become ``[obs | state]`` in an ObsStateBox (rlchain's central-value layout); torch
observations make it a tensor env on their device. An IVecEnv resets finished envs itself and does
not report their last observation: ``final_obs`` is the observation before the step, so time-out
bootstrapping uses V(s_T-1), the value rl_games itself bootstraps with.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.envs.gym_spaces import spaces_to_gymnasium
from rlchain.envs.tensors import is_tensor
from rlchain.envs.vecenv import StepResult, VecEnv, close_env
from rlchain.envs.wrappers.central_value import ObsStateBox


def make_registered_vecenv(creator: Callable[..., Any], env_name: str, num_actors: int, seed: int | None,
                           render: bool, env_config: dict) -> VecEnv:
    """Call ``creator`` the rl_games way and adapt what it returns (see the module docstring)."""
    params = inspect.signature(creator).parameters
    extra = {k: v for k, v in (("seed", seed), ("render", render)) if k in params}
    env = creator(env_name, num_actors, **extra, **env_config)
    return IVecEnvAdapter(env, num_actors) if callable(getattr(env, "get_env_info", None)) else env


class IVecEnvAdapter:
    """An rl_games IVecEnv as an rlchain VecEnv; other attributes (action masks, ...) are the env's."""

    def __init__(self, env: Any, num_actors: int) -> None:
        self.env = env
        info = spaces_to_gymnasium(dict(env.get_env_info()))  # gym 0.2x spaces (Isaac Lab's) as gymnasium
        agents = info.get("agents")
        if agents is None:
            count = getattr(env, "get_number_of_agents", None)
            agents = count() if callable(count) else 1
        self.num_agents = int(agents)
        self.num_actors = int(num_actors)
        self.num_envs = self.num_actors * self.num_agents  # one row per agent (rl_games' batch)
        self.value_size = int(info.get("value_size", 1))
        self.action_space: gym.Space = info["action_space"]
        obs_space: gym.Space = info["observation_space"]
        self._state_space: gym.Space | None = info.get("state_space")
        self.use_central_value = self._state_space is not None
        if self.use_central_value:
            obs_space = ObsStateBox(gym.spaces.flatdim(obs_space), gym.spaces.flatdim(self._state_space),
                                    obs_space=obs_space, state_space=self._state_space)
        self.observation_space = obs_space
        self._obs = self._pending = self._obs_of(env.reset())  # the first obs tells numpy from tensors
        rows = len(self._obs)
        if rows != self.num_envs:  # an env built once for N envs (Isaac Lab's) asked for another count
            raise ValueError(f"the IVecEnv returned {rows} observation rows, expected num_actors ({self.num_actors})"
                             f" x agents ({self.num_agents}) = {self.num_envs}; set num_actors to its env count "
                             f"(to play: player.use_vecenv: True and player.num_actors: {rows // self.num_agents})")
        self.is_tensor_env = is_tensor(self._obs)
        if self.is_tensor_env:
            self.device = self._obs.device

    def get_number_of_agents(self) -> int:
        return self.num_agents

    def reset(self, seed: int | None = None) -> Any:
        """The env's ``reset()`` (an IVecEnv takes no seed; the creator seeds it)."""
        obs = self._pending if self._pending is not None else self._obs_of(self.env.reset())
        self._obs, self._pending = obs, None
        return obs

    def step(self, actions: Any) -> StepResult:
        prev = self._obs
        obs, rewards, dones, infos = self.env.step(actions)
        obs = self._obs = self._obs_of(obs)
        self._pending = None
        if isinstance(infos, (list, tuple)):  # one info dict per env (gym-style vec envs): observers get the list
            infos = {"env_infos": list(infos)}
        infos = infos if isinstance(infos, dict) else {}
        time_outs = infos.get("time_outs")
        if self.is_tensor_env:
            import torch  # a tensor env: torch is imported already

            dones = torch.as_tensor(dones, device=self.device).reshape(-1).bool()
            outs = (torch.zeros_like(dones) if time_outs is None
                    else torch.as_tensor(time_outs, device=self.device).reshape(-1).bool())
            rewards = torch.as_tensor(rewards, device=self.device).float()
        else:
            dones = np.asarray(dones).reshape(-1).astype(bool)
            outs = np.zeros_like(dones) if time_outs is None else np.asarray(time_outs).reshape(-1).astype(bool)
            rewards = np.asarray(rewards, dtype=np.float32)
        if self.value_size == 1:
            rewards = rewards.reshape(-1)
        truncated = dones & outs
        return StepResult(obs, rewards, dones & ~outs, truncated, prev, infos)

    def close(self) -> None:
        close_env(self.env)

    def _obs_of(self, obs: Any) -> Any:
        """The observation rows rlchain trains on: ``obs['obs']`` (and ``[obs | state]`` with a state)."""
        if isinstance(obs, dict):
            state = obs.get("states", obs.get("state")) if self.use_central_value else None
            obs = obs["obs"]
            if state is not None:
                if is_tensor(obs):
                    import torch

                    return torch.cat([obs.reshape(obs.shape[0], -1), state.reshape(state.shape[0], -1)], -1).float()
                return np.concatenate([np.asarray(obs, np.float32).reshape(len(obs), -1),
                                       np.asarray(state, np.float32).reshape(len(state), -1)], -1)
        return obs

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_") or name == "env":
            raise AttributeError(name)
        return getattr(self.env, name)


__all__ = ["IVecEnvAdapter", "make_registered_vecenv"]
