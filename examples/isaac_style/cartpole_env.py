"""An env in the shape Isaac Lab hands to rl_games, for running Isaac-Lab-style scripts without Isaac Sim.

Two parts, standing in for the two Isaac Lab packages a ``train.py`` imports:

- :class:`CartpoleDirectEnv` (isaaclab_tasks' direct cart-pole): N cart-poles stepped as torch tensors
  on one device (rlchain's TorchCartPole physics with a continuous force in [-1, 1]);
  ``step(actions) -> (obs_dict, reward, terminated, truncated, extras)`` with observation groups
  ``{"policy": (N, 4), "critic": (N, 6)}`` and per-episode statistics in ``extras["log"]``;
- :class:`RlGamesVecEnvWrapper` and :class:`RlGamesGpuEnv` (isaaclab_rl.rl_games): the rl_games
  ``IVecEnv`` views of it. Observations ``{"obs": ..., "states": ...}`` clipped to ``clip_obs``, actions
  clipped to ``clip_actions``, ``dones = terminated | truncated``, time-outs in ``infos["time_outs"]``,
  ``extras["log"]`` renamed ``infos["episode"]``, everything on the RL device.

The wrappers are written against rl_games' names (``rl_games.common.vecenv.IVecEnv``), so they run under
``python -m rlchain.rl_games`` (rlchain) and under rl_games alike.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import torch
from rl_games.common import env_configurations
from rl_games.common.vecenv import IVecEnv

from rlchain.envs.backends.torch_envs.cartpole import TorchCartPole


class ContinuousCartPole(TorchCartPole):
    """TorchCartPole pushed by a continuous force: action (N, 1) in [-1, 1] times ``force_mag``."""

    def __init__(self, num_envs: int, device: str = "cpu", seed: int | None = None,
                 max_episode_steps: int | None = 300) -> None:
        super().__init__(num_envs, device, seed, max_episode_steps)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def _force(self, actions: torch.Tensor) -> torch.Tensor:
        return actions[:, 0].clamp(-1.0, 1.0) * self.force_mag


class CartpoleDirectEnv:
    """A direct-workflow env as Isaac Lab writes them: batched tensors on ``device``, observation groups,
    ``extras["log"]`` with the mean statistics of the episodes that ended at this step."""

    num_observations = 4
    num_states = 6  # the critic sees the observation plus the pole's tip position

    def __init__(self, num_envs: int, device: str = "cpu", seed: int | None = None,
                 max_episode_steps: int = 300) -> None:
        self.sim = ContinuousCartPole(num_envs, device, seed, max_episode_steps)
        self.num_envs = num_envs
        self.device = self.sim.device
        self.max_episode_length = max_episode_steps
        self.episode_return = torch.zeros(num_envs, device=self.device)
        self.extras: dict = {}

    @property
    def unwrapped(self) -> CartpoleDirectEnv:
        return self

    def _groups(self, obs: torch.Tensor) -> dict[str, torch.Tensor]:
        tip = torch.stack((obs[:, 0] + torch.sin(obs[:, 2]), torch.cos(obs[:, 2])), 1)
        return {"policy": obs, "critic": torch.cat((obs, tip), 1)}

    def reset(self) -> tuple[dict[str, torch.Tensor], dict]:
        self.episode_return.zero_()
        return self._groups(self.sim.reset()), {}

    def step(self, actions: torch.Tensor):
        result = self.sim.step(actions)
        reward = result.reward
        self.episode_return += reward
        done = result.terminated | result.truncated
        self.extras = {}
        if bool(done.any()):
            ids = done.nonzero().squeeze(-1)
            self.extras["log"] = {"Episode_Reward/alive": self.episode_return[ids].mean(),
                                  "Episode_Termination/time_out": result.truncated[ids].float().sum(),
                                  "Episode_Termination/pole_fell": (result.terminated[ids]).float().sum()}
            self.episode_return[ids] = 0.0
        return self._groups(result.obs), reward, result.terminated, result.truncated, self.extras

    def close(self) -> None:
        self.sim.close()


class RlGamesVecEnvWrapper(IVecEnv):
    """The rl_games view of a :class:`CartpoleDirectEnv` (Isaac Lab's wrapper of the same name)."""

    def __init__(self, env: CartpoleDirectEnv, rl_device: str, clip_obs: float, clip_actions: float) -> None:
        self.env = env
        self._rl_device = rl_device
        self._clip_obs = clip_obs
        self._clip_actions = clip_actions
        self._sim_device = env.device
        self.observation_space = gym.spaces.Box(-clip_obs, clip_obs, (env.num_observations,), np.float32)
        self.state_space = gym.spaces.Box(-math.inf, math.inf, (env.num_states,), np.float32)
        self.action_space = gym.spaces.Box(-clip_actions, clip_actions, (1,), np.float32)

    @property
    def unwrapped(self) -> CartpoleDirectEnv:
        return self.env.unwrapped

    @property
    def num_envs(self) -> int:
        return self.env.num_envs

    def get_number_of_agents(self) -> int:
        return 1

    def get_env_info(self) -> dict:
        return {"observation_space": self.observation_space, "action_space": self.action_space,
                "state_space": self.state_space}

    def reset(self):
        obs_dict, _ = self.env.reset()
        return self._process_obs(obs_dict)

    def step(self, actions: torch.Tensor):
        actions = actions.detach().clone().to(device=self._sim_device)
        actions = torch.clamp(actions, -self._clip_actions, self._clip_actions)
        obs_dict, rew, terminated, truncated, extras = self.env.step(actions)
        extras = dict(extras)
        extras["time_outs"] = truncated.to(device=self._rl_device)  # for value bootstrapping
        obs_and_states = self._process_obs(obs_dict)
        rew = rew.to(device=self._rl_device)
        dones = (terminated | truncated).to(device=self._rl_device)
        extras = {k: v.to(device=self._rl_device) if hasattr(v, "to") else v for k, v in extras.items()}
        if "log" in extras:  # Isaac Lab's statistics, under the key rl_games' observers read
            extras["episode"] = extras.pop("log")
        return obs_and_states, rew, dones, extras

    def close(self) -> None:
        self.env.close()

    def _process_obs(self, obs_dict: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        obs = torch.clamp(obs_dict["policy"], -self._clip_obs, self._clip_obs).to(device=self._rl_device)
        states = obs_dict["critic"].to(device=self._rl_device)
        return {"obs": obs, "states": states}


class RlGamesGpuEnv(IVecEnv):
    """What ``vecenv_type: IsaacRlgWrapper`` builds: the env that ``env_configurations`` holds."""

    def __init__(self, config_name: str, num_actors: int, **kwargs) -> None:
        self.env: RlGamesVecEnvWrapper = env_configurations.configurations[config_name]["env_creator"](**kwargs)

    def step(self, action):
        return self.env.step(action)

    def reset(self):
        return self.env.reset()

    def get_number_of_agents(self) -> int:
        return self.env.get_number_of_agents()

    def get_env_info(self) -> dict:
        return self.env.get_env_info()
