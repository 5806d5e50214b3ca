"""TorchPush2D-v0: a planar push-cube task as batched torch math, with EmbodiChain's push_cube start
distribution, reward terms and success test.

A gripper (a disc of radius 0.02 m) moves by position deltas: action a in [-1, 1]^2 moves it by
``step_size`` * a per step inside a 0.5 m square. A cube (treated as a disc of radius 0.025 m) is pushed
quasi-statically: when the gripper overlaps it, the cube moves out along the line between their centres
until they just touch. Starts as EmbodiChain's push_cube: the cube within 0.2 m of the centre, the goal
anywhere within 0.3 m, the gripper near (0, -0.4). Success (``info['success']``, terminates the episode):
the cube's planar distance to the goal under ``success_threshold`` (0.1 m); 100-step episodes.

Reward, EmbodiChain's push_cube terms with its weights (``terms()`` gives them unweighted):
0.03 x reaching (1 - tanh(8 d), d the gripper's distance to the point 0.03 m behind the cube, away from
the goal) + 0.8 x goal distance (exp(-d^2 / (2 0.12^2)), d cube to goal) - 0.01 x action change (squared)
+ 10 x success. Observation: gripper, cube, goal positions, the cube-to-goal and gripper-to-cube vectors,
the last action (12).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.tensor_env import TensorVecEnv
from rlchain.envs.vecenv import StepResult

WEIGHTS = {"reaching_reward": 0.03, "goal_distance_reward": 0.8, "action_penalty": -0.01, "success_bonus": 10.0}


class TorchPush2D(TensorVecEnv):
    """N planar push tasks; ``state`` (N, 8): gripper xy, cube xy, goal xy, last action."""

    gripper_radius = 0.02
    cube_radius = 0.025
    half_width = 0.5

    def __init__(self, num_envs: int, device: str | torch.device = "cpu", seed: int | None = None,
                 max_episode_steps: int | None = 100, success_threshold: float = 0.1,
                 step_size: float = 0.03) -> None:
        super().__init__(num_envs, device, seed, max_episode_steps)
        self.success_threshold, self.step_size = float(success_threshold), float(step_size)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (12,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.state = torch.zeros(self.num_envs, 8, device=self.device)
        self.last_terms: dict[str, torch.Tensor] = {}
        self.success = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)

    def _obs(self, state: torch.Tensor) -> torch.Tensor:
        g, c, goal, a = state[:, 0:2], state[:, 2:4], state[:, 4:6], state[:, 6:8]
        return torch.cat((g, c, goal, goal - c, c - g, a), 1)

    def _reset_idx(self, env_ids: torch.Tensor) -> torch.Tensor:
        k = env_ids.numel()
        gripper = torch.stack((self.uniform((k,), -0.05, 0.05), self.uniform((k,), -0.45, -0.35)), 1)
        new = torch.cat((gripper, self.uniform((k, 2), -0.2, 0.2), self.uniform((k, 2), -0.3, 0.3),
                         torch.zeros(k, 2, device=self.device)), 1)
        self.state = self.state.index_put((env_ids,), new)
        return self._obs(new)

    def _step_physics(self, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        a = actions.clamp(-1.0, 1.0)
        g, c, goal, last = self.state[:, 0:2], self.state[:, 2:4], self.state[:, 4:6], self.state[:, 6:8]
        g = (g + self.step_size * a).clamp(-self.half_width, self.half_width)
        offset = c - g
        dist = offset.norm(dim=-1, keepdim=True).clamp(min=1e-6)
        contact = self.gripper_radius + self.cube_radius
        push = (contact - dist).clamp(min=0.0)  # overlap: the cube moves out along the centre line
        c = (c + offset / dist * push).clamp(-self.half_width, self.half_width)
        self.state = torch.cat((g, c, goal, a), 1)
        to_goal = goal - c
        d_goal = to_goal.norm(dim=-1)
        behind = c - to_goal / d_goal.unsqueeze(-1).clamp(min=1e-6) * (contact + 0.03)
        self.success = d_goal < self.success_threshold
        self.last_terms = {"reaching_reward": 1.0 - torch.tanh(8.0 * (g - behind).norm(dim=-1)),
                           "goal_distance_reward": torch.exp(-d_goal.square() / (2 * 0.12 ** 2)),
                           "action_penalty": (a - last).square().sum(-1),
                           "success_bonus": self.success.float()}
        reward = sum(WEIGHTS[k] * v for k, v in self.last_terms.items())
        return self._obs(self.state), reward, self.success.clone()

    def step(self, actions: Any) -> StepResult:
        result = super().step(actions)
        result.infos["success"] = self.success
        return result

    def detach_state(self) -> torch.Tensor:
        """Cut the autograd graph (truncated backpropagation): the current observations, detached."""
        self.state = self.state.detach()
        return self._obs(self.state)
