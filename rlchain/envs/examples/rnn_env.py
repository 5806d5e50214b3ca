"""rl_games' memory test env ``TestRnnEnv-v0``: find a goal that was shown only at the start.

The agent starts at (0, 0); the goal lies ``min_dist``..``max_dist`` squares away on each axis
(random signs). With ``hide_object: True`` the goal is in the observation only for the first
``show_time`` observations (the reset one when 1), and the first action is ignored, so every
later move depends on an observation seen several steps before: a recurrent policy can
remember it and reach the goal nearly always, a feedforward one follows a path that cannot
depend on the goal and rarely finds it. Reaching the goal gives reward 1 and ends the episode
(``terminated``, ``info['scores'] = 1``); ``max_steps`` steps without it is a time-out
(``truncated``, ``info['scores'] = 0``).

Observation (6,) float32: position (2), goal (2, zeros while hidden), 1 while the goal is shown
else 0, steps taken. Actions: Discrete(4) (+x, -x, +y, -y), or with ``multi_discrete_space`` a
Tuple(Discrete(2), Discrete(3)) (x: +/-, y: +/-/stay). rl_games' other options work as there:
``apply_dist_reward`` (a -0.1 * distance / max_dist shaping term), ``multi_head_value`` (reward
(2,) = [goal, distance term], ``value_size = 2``), ``multi_obs_space`` (Dict ``pos`` (2,) /
``info`` (4,), plus ``aux_target`` (1,) with ``aux_loss``) and ``use_central_value`` (Dict
``{'obs', 'state'}``, the state never hiding the goal).

rl_games' ``env_name: test_env`` (gymnasium id in ``env_config.name``) is registered too, so
rl_games' ``configs/test/test_rnn*.yaml`` name it as written.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.envs.building import openai_gym_env


class TestRNNEnv(gym.Env):
    """See the module docstring; keyword arguments are rl_games' names."""

    metadata = {"render_modes": []}
    __test__ = False  # not a pytest test class

    def __init__(self, max_steps: int = 21, show_time: int = 1, min_dist: int = 2, max_dist: int = 8,
                 hide_object: bool = False, use_central_value: bool = False, apply_dist_reward: bool = False,
                 apply_exploration_reward: bool = False, multi_head_value: bool = False, aux_loss: bool = False,
                 multi_discrete_space: bool = False, multi_obs_space: bool = False) -> None:
        del apply_exploration_reward  # accepted for rl_games configs; it has no effect there either
        if not 0 < min_dist <= max_dist:
            raise ValueError(f"need 0 < min_dist <= max_dist, got {min_dist}, {max_dist}")
        self.max_steps, self.show_time = int(max_steps), int(show_time)
        self.min_dist, self.max_dist = int(min_dist), int(max_dist)
        self.hide_object, self.use_central_value = bool(hide_object), bool(use_central_value)
        self.apply_dist_reward, self.multi_head_value = bool(apply_dist_reward), bool(multi_head_value)
        self.aux_loss, self.multi_discrete_space = bool(aux_loss), bool(multi_discrete_space)
        self.multi_obs_space = bool(multi_obs_space)
        self.value_size = 2 if self.multi_head_value else 1
        self.action_space = gym.spaces.Tuple([gym.spaces.Discrete(2), gym.spaces.Discrete(3)]) \
            if self.multi_discrete_space else gym.spaces.Discrete(4)
        self.state_space = self._obs_space()
        self.observation_space = gym.spaces.Dict({"obs": self.state_space, "state": self.state_space}) \
            if self.use_central_value else self.state_space
        self.pos = np.zeros(2, dtype=np.int64)
        self.goal = np.zeros(2, dtype=np.int64)
        self.steps = 0

    def _obs_space(self) -> gym.Space:
        bound = float(max(self.max_steps, self.max_dist))
        if not self.multi_obs_space:
            return gym.spaces.Box(-bound, bound, (6,), np.float32)
        spaces = {"pos": gym.spaces.Box(-bound, bound, (2,), np.float32),
                  "info": gym.spaces.Box(-bound, bound, (4,), np.float32)}
        if self.aux_loss:
            spaces["aux_target"] = gym.spaces.Box(0.0, np.inf, (1,), np.float32)
        return gym.spaces.Dict(spaces)

    def get_number_of_agents(self) -> int:
        return 1

    def has_action_mask(self) -> bool:
        return False

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.steps = 0
        self.pos = np.zeros(2, dtype=np.int64)
        signs = 1 - 2 * self.np_random.integers(0, 2, size=2)
        self.goal = signs * self.np_random.integers(self.min_dist, self.max_dist + 1, size=2)
        return self._observe(), {}

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict]:
        self.steps += 1
        if self.steps > 1:  # the first action is ignored (rl_games): the goal must be remembered
            self.pos += self._move(action)
        reached = bool((self.pos == self.goal).all())
        truncated = not reached and self.steps >= self.max_steps
        dist_term = -0.1 * float(np.abs(self.pos - self.goal).sum()) / self.max_dist if self.apply_dist_reward else 0.0
        reward = np.array([1.0 if reached else 0.0, dist_term], dtype=np.float32)
        info = {"scores": 1 if reached else 0} if reached or truncated else {}
        out_reward = reward if self.multi_head_value else np.float32(reward.sum())
        return self._observe(), out_reward, reached, truncated, info

    def _move(self, action: Any) -> np.ndarray:
        if self.multi_discrete_space:
            x, y = (int(a) for a in np.asarray(action).reshape(-1)[:2])
            return np.array([1 if x == 0 else -1, {0: 1, 1: -1}.get(y, 0)], dtype=np.int64)
        return np.array([(1, 0), (-1, 0), (0, 1), (0, -1)][int(np.asarray(action).reshape(-1)[0])], dtype=np.int64)

    def _observe(self) -> Any:
        shown = not self.hide_object or self.steps < self.show_time
        goal = self.goal if shown else np.zeros(2, dtype=np.int64)
        obs = self._pack(np.concatenate([self.pos, goal, [1 if shown else 0, self.steps]]).astype(np.float32))
        if not self.use_central_value:
            return obs
        state = np.concatenate([self.pos, self.goal, [1, self.steps]]).astype(np.float32)
        return {"obs": obs, "state": self._pack(state)}

    def _pack(self, flat: np.ndarray) -> Any:
        if not self.multi_obs_space:
            return flat
        out = {"pos": flat[:2], "info": flat[2:]}
        if self.aux_loss:
            bound = self.max_dist - self.min_dist or 1
            out["aux_target"] = np.array([((self.goal - self.pos) ** 2).sum() / bound ** 2], dtype=np.float32)
        return out


def test_env(num_envs: int, seed: int | None = None, *, vecenv_type: str | None = None, render: bool = False,
             **env_config: Any) -> Any:
    """rl_games' ``env_name: test_env``: the gymnasium id in ``env_config.name``, the rest its kwargs."""

    return openai_gym_env(num_envs, seed, vecenv_type=vecenv_type, render=render, **env_config)


test_env.__test__ = False  # not a pytest test
