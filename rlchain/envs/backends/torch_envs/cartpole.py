"""TorchCartPole-v0: gymnasium's CartPole-v1 as batched tensor math.

Same constants, equations, Euler integrator, termination thresholds (|x| > 2.4,
|theta| > 12 degrees), reward 1 on every step (the terminating one included), a 500-step time
limit and initial state U(-0.05, 0.05)^4. The state is float32 (gymnasium keeps float64): a
trajectory agrees with gymnasium's to about 1e-6 over tens of steps (tests/unit/test_tensor_envs.py).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.tensor_env import TensorVecEnv


class TorchCartPole(TensorVecEnv):
    """N cart-poles; ``state`` is (N, 4): x, x_dot, theta, theta_dot. Actions int64 (N,) in {0, 1}."""

    gravity = 9.8
    masscart = 1.0
    masspole = 0.1
    total_mass = masspole + masscart
    length = 0.5  # half the pole's length
    polemass_length = masspole * length
    force_mag = 10.0
    tau = 0.02
    theta_threshold_radians = 12 * 2 * math.pi / 360
    x_threshold = 2.4

    def __init__(self, num_envs: int, device: str | torch.device = "cpu", seed: int | None = None,
                 max_episode_steps: int | None = 500) -> None:
        super().__init__(num_envs, device, seed, max_episode_steps)
        high = np.array([self.x_threshold * 2, np.inf, self.theta_threshold_radians * 2, np.inf],
                        dtype=np.float32)
        self.observation_space = gym.spaces.Box(-high, high, dtype=np.float32)
        self.action_space = gym.spaces.Discrete(2)
        self.state = torch.zeros(self.num_envs, 4, device=self.device)

    def _reset_idx(self, env_ids: torch.Tensor) -> torch.Tensor:
        new = self.uniform((env_ids.numel(), 4), -0.05, 0.05)
        self.state[env_ids] = new
        return new.clone()

    def _force(self, actions: torch.Tensor) -> torch.Tensor:
        """The force (N,) on each cart: action 1 -> +force_mag, 0 -> -force_mag. A subclass with another
        action space (a continuous force) overrides it."""
        return (actions * 2 - 1).float() * self.force_mag

    def _step_physics(self, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        x, x_dot, theta, theta_dot = self.state.unbind(1)
        force = self._force(actions)
        costheta = torch.cos(theta)
        sintheta = torch.sin(theta)
        temp = (force + self.polemass_length * theta_dot.square() * sintheta) / self.total_mass
        thetaacc = (self.gravity * sintheta - costheta * temp) / (
            self.length * (4.0 / 3.0 - self.masspole * costheta.square() / self.total_mass))
        xacc = temp - self.polemass_length * thetaacc * costheta / self.total_mass
        # euler: positions move with the old velocities
        state = torch.stack((x + self.tau * x_dot, x_dot + self.tau * xacc,
                             theta + self.tau * theta_dot, theta_dot + self.tau * thetaacc), 1)
        self.state = state
        terminated = (state[:, 0].abs() > self.x_threshold) | (state[:, 2].abs() > self.theta_threshold_radians)
        # fresh tensors: a caller may keep or modify what step returns without touching the state
        return state.clone(), torch.ones(self.num_envs, device=self.device), terminated
