"""TorchPointMass-v0: a damped 2-D point mass pushed to a goal; differentiable end to end.

State per env: position p, velocity v, goal g (each (2,)). Action a in [-1, 1]^2 is a force:
v' = v (1 - damping dt) + force_scale a dt, p' = clip(p + v' dt, -1, 1). Reward -|p' - g| (plus
``success_bonus`` on success); the episode terminates when |p' - g| < ``success_threshold`` (info
``success``) and is truncated at ``max_episode_steps``. Observation (p, v, g). Starts p ~ U(-0.6, 0.6)^2,
g ~ U(-0.7, 0.7)^2.

Every step is torch math without in-place writes on the state, so gradients flow from rewards to
actions across steps (APG); :meth:`TorchPointMass.detach_state` cuts the graph between segments.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.tensor_env import TensorVecEnv


class TorchPointMass(TensorVecEnv):
    """N point masses; ``state`` (N, 6): position, velocity, goal. Actions float32 (N, 2) in [-1, 1]."""

    info_attrs = ("success",)

    def __init__(self, num_envs: int, device: str | torch.device = "cpu", seed: int | None = None,
                 max_episode_steps: int | None = 100, success_threshold: float = 0.05,
                 success_bonus: float = 0.0, force_scale: float = 5.0, damping: float = 5.0,
                 dt: float = 1.0 / 30.0) -> None:
        super().__init__(num_envs, device, seed, max_episode_steps)
        self.success_threshold, self.success_bonus = float(success_threshold), float(success_bonus)
        self.force_scale, self.damping, self.dt = float(force_scale), float(damping), float(dt)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (6,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.state = torch.zeros(self.num_envs, 6, device=self.device)
        self.success = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)

    def _reset_idx(self, env_ids: torch.Tensor) -> torch.Tensor:
        k = env_ids.numel()
        new = torch.cat((self.uniform((k, 2), -0.6, 0.6), torch.zeros(k, 2, device=self.device),
                         self.uniform((k, 2), -0.7, 0.7)), 1)
        self.state = self.state.index_put((env_ids,), new)  # out of place: the graph stays intact
        return new.clone()

    def _step_physics(self, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        p, v, g = self.state[:, 0:2], self.state[:, 2:4], self.state[:, 4:6]
        a = actions.clamp(-1.0, 1.0)
        v = v * (1.0 - self.damping * self.dt) + self.force_scale * a * self.dt
        p = (p + v * self.dt).clamp(-1.0, 1.0)
        self.state = torch.cat((p, v, g), 1)
        distance = (p - g).norm(dim=-1)
        self.success = (distance < self.success_threshold).detach()
        reward = -distance + self.success_bonus * self.success.float()
        return self.state.clone(), reward, self.success.clone()

    def detach_state(self) -> torch.Tensor:
        """Cut the autograd graph (truncated backpropagation): the current observations, detached."""
        self.state = self.state.detach()
        return self.state.clone()
