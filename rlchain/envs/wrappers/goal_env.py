"""Goal envs (gymnasium-robotics style): ``compute_reward(achieved_goal, desired_goal, info)`` for a VecEnv.

Hindsight replay (``rlchain/algos/off_policy/her.py``) recomputes rewards for goals the env never set, so it
needs the env's reward as a function of the goals:

- a gymnasium env that defines ``compute_reward`` (gymnasium-robotics, ``TestGoalReach-v0``): the
  backend calls it on one extra copy of the env (:meth:`GymnasiumVecEnv.compute_reward`);
- envpool's Fetch tasks compute their reward in C++ and expose no ``compute_reward``; their reward is
  gymnasium-robotics' documented Fetch reward, :func:`fetch_compute_reward`, with the task's own
  ``distance_threshold`` and ``reward_type`` (:meth:`EnvpoolVecEnv.compute_reward`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

RewardFn = Callable[[np.ndarray, np.ndarray, Any], np.ndarray]


def fetch_compute_reward(achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None,
                         distance_threshold: float = 0.05, reward_type: str = "sparse") -> np.ndarray:
    """gymnasium-robotics' documented Fetch reward, batched over the leading axes: with d the
    Euclidean distance between the goals, ``-(d > distance_threshold)`` (sparse, 0 or -1) or
    ``-d`` (dense). float32 (...,)."""
    d = np.linalg.norm(np.asarray(achieved_goal, np.float64) - np.asarray(desired_goal, np.float64), axis=-1)
    if reward_type == "dense":
        return (-d).astype(np.float32)
    return -(d > distance_threshold).astype(np.float32)


def env_compute_reward(env: Any) -> RewardFn:
    """The VecEnv's ``compute_reward(achieved (B, G), desired (B, G), info) -> (B,)``; ValueError when
    the env has none (it is not a goal env)."""
    fn = getattr(env, "compute_reward", None)
    if fn is None:
        raise ValueError(f"{type(env).__name__} has no compute_reward: hindsight replay needs a goal env "
                         f"(gymnasium-robotics style, or an envpool Fetch task)")
    return fn
