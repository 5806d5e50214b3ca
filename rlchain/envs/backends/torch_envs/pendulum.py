"""TorchPendulum-v0: gymnasium's Pendulum-v1 as batched tensor math.

Same dynamics (g = 10, m = l = 1, dt = 0.05, speed clipped to 8, torque clipped to 2), reward
-(angle_normalize(th)^2 + 0.1 thdot^2 + 0.001 u^2) computed on the state before the step, obs
(cos th, sin th, thdot), no termination, a 200-step time limit and initial state
th ~ U(-pi, pi), thdot ~ U(-1, 1). float32 state (gymnasium: float64). The step is differentiable
(no in-place writes on the state): APG backpropagates through it, :meth:`TorchPendulum.detach_state`
cuts the graph between segments.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.tensor_env import TensorVecEnv


def angle_normalize(x: torch.Tensor) -> torch.Tensor:
    """Wrap to [-pi, pi) exactly like gymnasium (floor modulo)."""
    return torch.remainder(x + math.pi, 2 * math.pi) - math.pi


class TorchPendulum(TensorVecEnv):
    """N pendulums; ``state`` is (N, 2): th, thdot. Actions float32 (N, 1), torque in [-2, 2]."""

    max_speed = 8.0
    max_torque = 2.0
    dt = 0.05
    m = 1.0
    l = 1.0  # noqa: E741  (gymnasium's name)

    def __init__(self, num_envs: int, device: str | torch.device = "cpu", seed: int | None = None,
                 max_episode_steps: int | None = 200, g: float = 10.0) -> None:
        super().__init__(num_envs, device, seed, max_episode_steps)
        self.g = float(g)
        high = np.array([1.0, 1.0, self.max_speed], dtype=np.float32)
        self.observation_space = gym.spaces.Box(-high, high, dtype=np.float32)
        self.action_space = gym.spaces.Box(-self.max_torque, self.max_torque, shape=(1,), dtype=np.float32)
        self.state = torch.zeros(self.num_envs, 2, device=self.device)
        self._high = torch.tensor([math.pi, 1.0], device=self.device)

    def _obs(self, state: torch.Tensor) -> torch.Tensor:
        th, thdot = state[:, 0], state[:, 1]
        return torch.stack((torch.cos(th), torch.sin(th), thdot), 1)

    def _reset_idx(self, env_ids: torch.Tensor) -> torch.Tensor:
        new = self.uniform((env_ids.numel(), 2), -self._high, self._high)
        self.state = self.state.index_put((env_ids,), new)  # out of place: differentiable (APG)
        return self._obs(new)

    def _step_physics(self, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        th, thdot = self.state.unbind(1)
        u = actions[:, 0].clamp(-self.max_torque, self.max_torque)
        costs = angle_normalize(th).square() + 0.1 * thdot.square() + 0.001 * u.square()
        newthdot = thdot + (3 * self.g / (2 * self.l) * torch.sin(th) + 3.0 / (self.m * self.l ** 2) * u) * self.dt
        newthdot = newthdot.clamp(-self.max_speed, self.max_speed)
        newth = th + newthdot * self.dt
        self.state = torch.stack((newth, newthdot), 1)
        return self._obs(self.state), -costs, torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)

    def detach_state(self) -> torch.Tensor:
        """Cut the autograd graph (truncated backpropagation): the current observations, detached."""
        self.state = self.state.detach()
        return self._obs(self.state)
