"""One gymnasium env as a VecEnv of one env, for playing and recording a single env (video)."""

from __future__ import annotations

from typing import Any

import numpy as np

from rlchain.envs.vecenv import StepResult
from rlchain.envs.wrappers.spaces import cast_actions, cast_obs


class OneEnv:
    """One gymnasium env (the recording env) as a VecEnv of ``num_envs = 1`` for
    :func:`rlchain.policy.play.play`.

    An ended episode is reset in the same step (the VecEnv contract), episode ``k`` seeded
    ``seed + k``, except after the ``games``-th: RecordVideo would start one more video.
    """

    num_envs = 1

    def __init__(self, env: Any, games: int) -> None:

        self.env, self.games = env, games
        self.observation_space, self.action_space = env.observation_space, env.action_space
        self._cast_actions, self._cast_obs = cast_actions, cast_obs
        self._seed: int | None = None
        self._episode = 0
        self._mask = getattr(env.unwrapped, "get_action_mask", None)

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Start episode 0 (seeded ``seed``); returns its observation as a batch of one."""
        self._seed, self._episode = seed, 0
        return self._reset()

    def _reset(self) -> np.ndarray:
        seed = None if self._seed is None else self._seed + self._episode
        obs, _ = self.env.reset(seed=seed)
        return self._cast_obs(np.asarray(obs)[None])

    def step(self, actions: np.ndarray) -> StepResult:
        """Step with actions (1, ...); an ended episode is followed by the next one's reset."""
        action = self._cast_actions(actions, self.action_space, 1)[0]
        obs, reward, terminated, truncated, _ = self.env.step(action)
        obs = self._cast_obs(np.asarray(obs)[None])
        final = obs
        if terminated or truncated:
            self._episode += 1
            if self._episode < self.games:
                obs = self._reset()
        return StepResult(obs, np.array([reward], np.float32), np.array([bool(terminated)]),
                          np.array([bool(truncated)]), final)

    def has_action_mask(self) -> bool:
        """Whether the recorded env offers ``get_action_mask()``."""
        return callable(self._mask)

    def get_action_mask(self) -> np.ndarray:
        """(1, mask_size) bool masks of the env's current state."""
        return np.asarray(self._mask(), dtype=bool)[None]

    def close(self) -> None:
        """Close the recording env (RecordVideo writes its last video)."""
        self.env.close()
