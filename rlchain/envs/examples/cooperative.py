"""Two cooperating agents that must agree where to meet (``TestCooperativeEnv-v0``, multi-agent).

A corridor of ``length`` cells holds two flags at distinct random cells and two agents at random
cells. Both agents get +1 and the episode ends when they stand on the *same* flag at once; every
other step costs each of them ``step_cost``; 20 steps without meeting is a time-out. Each agent
moves left / stays / moves right (Discrete(3)).

Meeting needs coordination: an agent that walks to its own nearest flag meets its partner only
when the partner's nearest flag is the same one (about half the games, see
:func:`nearest_flag_policy`), so the shared policy has to settle on a convention that uses the
partner's position as well as its own.

Agent ``j``'s observation (6,) float32, positions scaled by 1 / (length - 1): own position,
partner position, then (flag - own) for the left and right flag, then (flag - partner) for both.
It follows the multi-agent contract of :mod:`rlchain.envs.wrappers.multi_agent`: ``get_number_of_agents()
== 2``, obs (2, 6), actions (2,), rewards (2,), one ``terminated`` per env.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

LEFT, STAY, RIGHT = 0, 1, 2


class CooperativeEnv(gym.Env):
    """Two agents, two flags, one corridor: reward when both stand on the same flag."""

    metadata = {"render_modes": ["ansi"]}

    def __init__(self, length: int = 9, step_cost: float = 0.01, render_mode: str | None = None) -> None:
        if length < 3:
            raise ValueError(f"length must be >= 3, got {length}")
        self.length = int(length)
        self.step_cost = float(step_cost)
        self.render_mode = render_mode
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (6,), np.float32)
        self.action_space = gym.spaces.Discrete(3)
        self.pos = np.zeros(2, dtype=np.int64)
        self.flags = np.zeros(2, dtype=np.int64)

    def get_number_of_agents(self) -> int:
        return 2

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.flags = np.sort(self.np_random.choice(self.length, size=2, replace=False))
        self.pos = self.np_random.integers(0, self.length, size=2)
        return self._obs(), {}

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, bool, bool, dict]:
        moves = np.asarray(actions, dtype=np.int64).reshape(2) - 1  # -1, 0, +1
        self.pos = np.clip(self.pos + moves, 0, self.length - 1)
        met = bool(self.pos[0] == self.pos[1] and self.pos[0] in self.flags)
        reward = np.full(2, 1.0 if met else -self.step_cost, dtype=np.float32)
        return self._obs(), reward, met, False, {"met": met}

    def _obs(self) -> np.ndarray:
        scale = 1.0 / (self.length - 1)
        out = np.empty((2, 6), dtype=np.float32)
        for j in range(2):
            own, partner = self.pos[j], self.pos[1 - j]
            out[j] = [own, partner, self.flags[0] - own, self.flags[1] - own,
                      self.flags[0] - partner, self.flags[1] - partner]
        return out * scale

    def render(self) -> str:
        row = ["."] * self.length
        for f in self.flags:
            row[f] = "F"
        for j, p in enumerate(self.pos):
            row[p] = str(j) if row[p] != str(1 - j) else "*"
        return "".join(row)


def nearest_flag_policy(obs: np.ndarray) -> np.ndarray:
    """The uncoordinated baseline: each agent walks to its own nearest flag (ties: the left one).

    obs (k, 6) -> actions (k,).
    """
    to_left, to_right = obs[:, 2], obs[:, 3]
    target = np.where(np.abs(to_left) <= np.abs(to_right), to_left, to_right)
    return (np.sign(np.round(target, 6)) + 1).astype(np.int64)
