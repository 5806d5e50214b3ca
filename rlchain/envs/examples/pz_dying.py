"""A small PettingZoo-style ParallelEnv whose agents come and go (no pettingzoo import needed).

``env_config: {env: rlchain.envs.examples.pz_dying}``. Agents ``runner_0..runner_{n-1}`` start the
episode; ``runner_k`` terminates after ``k + 2`` steps. ``late_0`` appears at step 2 and terminates
at step 5. The episode is truncated after ``length`` steps. Every step an agent sees a one-hot
target (3 values) and gets +1 for choosing it, 0 otherwise, so a perfect agent's return is its
number of steps and a random one's a third of it.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np


class DyingParallelEnv:
    """PettingZoo's ParallelEnv API (possible_agents, agents, per-agent spaces, reset, step)."""

    metadata = {"name": "pz_dying_v0", "is_parallelizable": True}

    def __init__(self, runners: int = 3, length: int = 8, late: bool = True, render_mode: str | None = None) -> None:
        self.runners, self.length, self.late = runners, length, late
        self.possible_agents = [f"runner_{k}" for k in range(runners)] + (["late_0"] if late else [])
        self.agents: list[str] = []
        self._obs_space = gym.spaces.Box(0.0, 1.0, (3,), np.float32)
        self._act_space = gym.spaces.Discrete(3)
        self.rng = np.random.default_rng()
        self.t = 0
        self.targets: dict[str, int] = {}

    def observation_space(self, agent: str) -> gym.Space:
        return self._obs_space

    def action_space(self, agent: str) -> gym.Space:
        return self._act_space

    def _obs(self, agent: str) -> np.ndarray:
        self.targets[agent] = int(self.rng.integers(3))
        return np.eye(3, dtype=np.float32)[self.targets[agent]]

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.t = 0
        self.agents = [f"runner_{k}" for k in range(self.runners)]
        return {a: self._obs(a) for a in self.agents}, {a: {} for a in self.agents}

    def step(self, actions: dict) -> tuple[dict, dict, dict, dict, dict]:
        missing = [a for a in self.agents if a not in actions]
        extra = [a for a in actions if a not in self.agents]
        if missing or extra:
            raise ValueError(f"actions for {sorted(actions)}, agents alive {self.agents}")
        self.t += 1
        rewards = {a: float(int(actions[a]) == self.targets[a]) for a in self.agents}
        terms, truncs = {}, {}
        for a in self.agents:
            end = 5 if a == "late_0" else int(a.split("_")[1]) + 2
            terms[a] = self.t >= end
            truncs[a] = self.t >= self.length and not terms[a]
        obs = {a: self._obs(a) for a in self.agents}
        infos = {a: {} for a in self.agents}
        self.agents = [a for a in self.agents if not (terms[a] or truncs[a])]
        if self.late and self.t == 2:
            self.agents.append("late_0")
            obs["late_0"] = self._obs("late_0")
        return obs, rewards, terms, truncs, infos

    def render(self) -> None:
        return None

    def close(self) -> None:
        pass


def parallel_env(**kwargs: object) -> DyingParallelEnv:
    return DyingParallelEnv(**kwargs)
