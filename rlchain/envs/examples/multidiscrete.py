"""``TestMultiDiscrete-v0``: reach a goal on a grid with one sub-action per axis (rl_games' multidiscrete test).

The agent starts at the origin of a grid of half-width ``size`` and sees the offset to a random
goal. Each step it picks an x move in {-1, 0, +1} and a y move in {-2, -1, 0, +1, +2}: the
action space is ``MultiDiscrete([3, 5])`` (``tuple_actions: True``: ``Tuple(Discrete(3),
Discrete(5))``, the space rl_games' test env uses). Unequal sizes on purpose: the y move must
not overshoot, so the two heads learn different things.

Reward: the L1 progress toward the goal divided by the starting distance, so an episode that
reaches the goal returns exactly 1.0 and any detour less; episodes end at the goal
(terminated) or after ``max_steps`` (truncated). A random policy scores about -0.6 (it overshoots);
PPO reaches 0.98 in about a second of training (``rlchain/configs/ppo_test_multidiscrete.yaml``).

``dict_obs: True`` returns the observation as ``{'offset': (2,), 'time': (1,)}`` to exercise the
Dict-observation flattening; otherwise it is the same three numbers as one (3,) vector.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

ENV_ID = "TestMultiDiscrete-v0"
X_MOVES = np.array([-1, 0, 1])
Y_MOVES = np.array([-2, -1, 0, 1, 2])


class MultiDiscreteGoalEnv(gym.Env):
    """Grid goal reaching with a (3, 5) multi-discrete action; see the module docstring."""

    metadata = {"render_modes": []}

    def __init__(self, size: int = 4, max_steps: int = 10, tuple_actions: bool = False,
                 dict_obs: bool = False) -> None:
        if size < 1 or max_steps < 1:
            raise ValueError(f"size and max_steps must be >= 1, got {size}, {max_steps}")
        self.size, self.max_steps = int(size), int(max_steps)
        self.tuple_actions, self.dict_obs = bool(tuple_actions), bool(dict_obs)
        nvec = (len(X_MOVES), len(Y_MOVES))
        self.action_space = (gym.spaces.Tuple([gym.spaces.Discrete(n) for n in nvec]) if tuple_actions
                             else gym.spaces.MultiDiscrete(nvec))
        offset = gym.spaces.Box(-2.0, 2.0, (2,), np.float32)
        time = gym.spaces.Box(0.0, 1.0, (1,), np.float32)
        self.observation_space = (gym.spaces.Dict({"offset": offset, "time": time}) if dict_obs
                                  else gym.spaces.Box(-2.0, 2.0, (3,), np.float32))
        self.pos = np.zeros(2, dtype=np.int64)
        self.goal = np.zeros(2, dtype=np.int64)
        self.steps, self.start_dist = 0, 1

    def _obs(self) -> Any:
        offset = ((self.goal - self.pos) / self.size).astype(np.float32)
        time = np.array([self.steps / self.max_steps], dtype=np.float32)
        return {"offset": offset, "time": time} if self.dict_obs else np.concatenate([offset, time])

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.pos[:] = 0
        while True:
            self.goal = self.np_random.integers(-self.size, self.size + 1, size=2)
            if self.goal.any():
                break
        self.steps = 0
        self.start_dist = int(np.abs(self.goal).sum())
        return self._obs(), {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        ax, ay = (int(a) for a in action)  # a (2,) array, or a tuple of two ints for Tuple actions
        before = np.abs(self.goal - self.pos).sum()
        self.pos = np.clip(self.pos + (X_MOVES[ax], Y_MOVES[ay]), -self.size, self.size)
        after = np.abs(self.goal - self.pos).sum()
        self.steps += 1
        reward = float(before - after) / self.start_dist
        terminated = bool(after == 0)
        truncated = not terminated and self.steps >= self.max_steps
        return self._obs(), reward, terminated, truncated, {}
