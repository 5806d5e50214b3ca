"""TorchReacher8-v0: an 8-link planar arm moving its fingertip to a random target.

Each joint is a damped, torque-driven rotor (no coupling between joints, no gravity):
``qd += dt * (gain * a - damping * qd); q += dt * qd`` (semi-implicit Euler), action
a in [-1, 1]^8 (clipped). The links have length 1/8, so the arm reaches 1; the target is drawn
uniformly over the annulus 0.2 <= r <= 0.9 around the base. The arm starts almost straight
along +x (q ~ U(-0.1, 0.1), qd = 0).

Observation (3 * links + 4 = 28): cos q, sin q, qd, target xy, fingertip - target.
Reward (dense): -|fingertip - target| - ctrl_cost * |a|^2. No termination; 200-step limit.
Uniform random actions score about -200 an episode, zero actions about -220, a hand-written
Jacobian-transpose controller about -8 (PPO, ppo_torch_reacher8.yaml: -30 after 15-30 s on 2 CPU cores).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.tensor_env import TensorVecEnv


class TorchReacher(TensorVecEnv):
    """N arms of ``num_links`` links; state ``q``, ``qd`` (N, links) and ``target`` (N, 2)."""

    dt = 0.05
    gain = 10.0  # joint acceleration per unit action, rad/s^2
    damping = 5.0  # 1/s: top joint speed gain / damping = 2 rad/s

    def __init__(self, num_envs: int, device: str | torch.device = "cpu", seed: int | None = None,
                 max_episode_steps: int | None = 200, num_links: int = 8, ctrl_cost: float = 0.01,
                 target_radius: tuple[float, float] = (0.2, 0.9)) -> None:
        super().__init__(num_envs, device, seed, max_episode_steps)
        if int(num_links) < 1:
            raise ValueError(f"params.config.env_config.num_links must be >= 1, got {num_links}")
        r0, r1 = (float(r) for r in target_radius)
        if not 0 <= r0 <= r1 <= 1:
            raise ValueError(f"params.config.env_config.target_radius must be [r0, r1] with 0 <= r0 <= r1 <= 1, "
                             f"got {target_radius}")
        self.num_links = n = int(num_links)
        self.link_length = 1.0 / n
        self.ctrl_cost = float(ctrl_cost)
        self.target_radius = (r0, r1)
        obs_dim = 3 * n + 4
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, shape=(obs_dim,), dtype=np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
        self.q = torch.zeros(self.num_envs, n, device=self.device)
        self.qd = torch.zeros(self.num_envs, n, device=self.device)
        self.target = torch.zeros(self.num_envs, 2, device=self.device)

    def fingertip(self, q: torch.Tensor) -> torch.Tensor:
        """Forward kinematics: (N, links) joint angles -> (N, 2) fingertip position."""
        angles = torch.cumsum(q, 1)
        return self.link_length * torch.stack((torch.cos(angles).sum(1), torch.sin(angles).sum(1)), 1)

    def _obs(self, q: torch.Tensor, qd: torch.Tensor, target: torch.Tensor, tip: torch.Tensor) -> torch.Tensor:
        return torch.cat((torch.cos(q), torch.sin(q), qd, target, tip - target), 1)

    def _reset_idx(self, env_ids: torch.Tensor) -> torch.Tensor:
        k, n = env_ids.numel(), self.num_links
        q = self.uniform((k, n), -0.1, 0.1)
        qd = torch.zeros(k, n, device=self.device)
        r0, r1 = self.target_radius
        radius = self.uniform((k,), r0 * r0, r1 * r1).sqrt()  # uniform over the annulus' area
        phi = self.uniform((k,), -math.pi, math.pi)
        target = torch.stack((radius * torch.cos(phi), radius * torch.sin(phi)), 1)
        self.q[env_ids], self.qd[env_ids], self.target[env_ids] = q, qd, target
        return self._obs(q, qd, target, self.fingertip(q))

    def _step_physics(self, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        a = actions.clamp(-1.0, 1.0)
        self.qd = self.qd + self.dt * (self.gain * a - self.damping * self.qd)
        self.q = self.q + self.dt * self.qd
        tip = self.fingertip(self.q)
        dist = torch.linalg.vector_norm(tip - self.target, dim=1)
        reward = -dist - self.ctrl_cost * a.square().sum(1)
        terminated = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        return self._obs(self.q, self.qd, self.target, tip), reward, terminated
