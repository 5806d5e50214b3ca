"""``TestMaskedActions-v0``: a task whose reward depends on respecting action masks.

Every step the env shows a preferred action (one-hot, per action dimension) and allows only some
actions: each is allowed with probability 1/2, the preferred one with probability
``p_preferred_valid`` (at least one action per dimension is always allowed). The env tells which
through rl_games' ``has_action_mask()`` / ``get_action_mask()``; the observation does not.

Per step and dimension: the preferred action, when allowed, earns 1; another allowed action
0.5; an action that is not allowed ends the episode with -1. Rewards are averaged over the
dimensions and divided by ``max_steps``, so the best possible mean return is
``p + (1 - p) / 2`` (0.875 with the default p = 0.75). With masks a policy learns this in
seconds; without them even the best policy keeps hitting forbidden actions.

Action spaces: ``Discrete(6)`` by default, ``MultiDiscrete([4, 3])`` with ``multi_discrete: True``
(unequal sizes on purpose: rl_games split such masks into equal parts and crashed). Masks are
(sum(nvec),) bool, the per-dimension masks concatenated. ``info['invalid_action']`` is True on the
step that broke a mask.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

ENV_ID = "TestMaskedActions-v0"


class MaskedActionsEnv(gym.Env):
    """See the module docstring."""

    metadata = {"render_modes": []}

    def __init__(self, multi_discrete: bool = False, max_steps: int = 10, p_preferred_valid: float = 0.75) -> None:
        self.nvec = [4, 3] if multi_discrete else [6]
        self.action_space = gym.spaces.MultiDiscrete(self.nvec) if multi_discrete else gym.spaces.Discrete(6)
        self.observation_space = gym.spaces.Box(0.0, 1.0, (sum(self.nvec),), np.float32)
        self.max_steps, self.p_valid = int(max_steps), float(p_preferred_valid)
        self.preferred = np.zeros(len(self.nvec), dtype=np.int64)
        self.masks = [np.ones(n, dtype=bool) for n in self.nvec]
        self.steps = 0

    # ----- rl_games' mask API ---------------------------------------------------------------
    def has_action_mask(self) -> bool:
        return True

    def get_action_mask(self) -> np.ndarray:
        """(sum(nvec),) bool: True where an action is allowed now."""
        return np.concatenate(self.masks)

    # ----- gymnasium API --------------------------------------------------------------------
    def _draw(self) -> np.ndarray:
        """New preferred actions and masks; returns the observation."""
        rng = self.np_random
        for k, n in enumerate(self.nvec):
            p = int(rng.integers(n))
            mask = rng.random(n) < 0.5
            mask[p] = rng.random() < self.p_valid
            if not mask.any():
                mask[(p + 1 + int(rng.integers(n - 1))) % n] = True
            self.preferred[k], self.masks[k] = p, mask
        obs = np.zeros(sum(self.nvec), dtype=np.float32)
        obs[np.cumsum([0, *self.nvec[:-1]]) + self.preferred] = 1.0
        return obs

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.steps = 0
        return self._draw(), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        actions = np.asarray(action, dtype=np.int64).reshape(-1)
        valid = all(self.masks[k][a] for k, a in enumerate(actions))
        self.steps += 1
        if not valid:
            return self._draw(), -1.0 / self.max_steps, True, False, {"invalid_action": True}
        score = np.mean([1.0 if a == self.preferred[k] else 0.5 for k, a in enumerate(actions)])
        truncated = self.steps >= self.max_steps
        return self._draw(), float(score) / self.max_steps, False, truncated, {"invalid_action": False}
