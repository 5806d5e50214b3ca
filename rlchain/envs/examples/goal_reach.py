"""``TestGoalReach-v0``: a point on a plane reaching a goal, the smallest task that reports success.

The point starts at a random position in [-1, 1]^2 and a goal is drawn in the same square; each
step moves it by ``0.1 * action`` (action in [-1, 1]^2, position clipped to the square). The
episode is a success once the point is within ``distance_threshold`` (0.1) of the goal.

- ``goal_dict: True`` (default): gymnasium-robotics style Dict observations ``observation``
  (the position), ``achieved_goal`` (the position), ``desired_goal`` (the goal), the sparse reward
  ``compute_reward(achieved, desired, info) = -(distance > threshold)`` and ``info['is_success']``,
  as the Fetch tasks: what hindsight replay needs.
- ``goal_dict: False``: a flat (4,) observation (position, goal), ``info['success']`` (MetaWorld's
  key); ``reward_type: dense`` gives ``-distance`` per step, so PPO learns it in seconds.

``max_steps`` (default 20) truncates the episode; ``terminate_on_success`` ends it on success.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

ENV_ID = "TestGoalReach-v0"


def goal_distance(achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
    """Euclidean distance over the last axis: (...,) for goals (..., 2)."""
    return np.linalg.norm(np.asarray(achieved) - np.asarray(desired), axis=-1)


class GoalReachEnv(gym.Env):
    """See the module docstring."""

    metadata = {"render_modes": []}

    def __init__(self, goal_dict: bool = True, reward_type: str = "sparse", max_steps: int = 20,
                 distance_threshold: float = 0.1, terminate_on_success: bool = False) -> None:
        if reward_type not in ("sparse", "dense"):
            raise ValueError(f"reward_type must be sparse or dense, got {reward_type!r}")
        self.goal_dict, self.reward_type = bool(goal_dict), reward_type
        self.max_steps, self.distance_threshold = int(max_steps), float(distance_threshold)
        self.terminate_on_success = bool(terminate_on_success)
        box = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        if self.goal_dict:
            self.observation_space = gym.spaces.Dict({"observation": box, "achieved_goal": box,
                                                      "desired_goal": box})
        else:
            self.observation_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.pos = np.zeros(2, np.float32)
        self.goal = np.zeros(2, np.float32)
        self.steps = 0

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any) -> np.ndarray:
        """Batched like gymnasium-robotics: goals (..., 2) -> rewards (...,): sparse 0 / -1, or -distance."""
        d = goal_distance(achieved_goal, desired_goal)
        if self.reward_type == "dense":
            return -d.astype(np.float32)
        return -(d > self.distance_threshold).astype(np.float32)

    def _obs(self) -> Any:
        if self.goal_dict:
            return {"observation": self.pos.copy(), "achieved_goal": self.pos.copy(), "desired_goal": self.goal.copy()}
        return np.concatenate([self.pos, self.goal]).astype(np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.pos = self.np_random.uniform(-1, 1, 2).astype(np.float32)
        self.goal = self.np_random.uniform(-1, 1, 2).astype(np.float32)
        self.steps = 0
        return self._obs(), {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        action = np.clip(np.asarray(action, dtype=np.float32).reshape(2), -1.0, 1.0)
        self.pos = np.clip(self.pos + 0.1 * action, -1.0, 1.0).astype(np.float32)
        self.steps += 1
        success = bool(goal_distance(self.pos, self.goal) <= self.distance_threshold)
        reward = float(self.compute_reward(self.pos, self.goal, None))
        info = {"is_success" if self.goal_dict else "success": float(success)}
        terminated = success and self.terminate_on_success
        return self._obs(), reward, terminated, self.steps >= self.max_steps, info
