"""The VecEnv contract every backend implements.

Shapes for ``num_envs = N``:

- ``reset(seed) -> obs``: obs (N, *observation_space.shape), numpy array or torch tensor.
- ``step(actions) -> StepResult``: actions (N, *action_space.shape) numpy array.
  ``obs`` is the observation to act on next: for an env whose episode just ended it is already
  the first observation of the next episode (same-step auto-reset). The true last observation of
  the ended episode is in ``final_obs`` at that row (rows of envs that did not end hold
  anything). ``reward`` (N,) float32, ``terminated`` and ``truncated`` (N,) bool, kept apart:
  truncation is a time-out, not a terminal state.
- ``observation_space`` / ``action_space``: the single-env gymnasium spaces.
- tensor envs set ``is_tensor_env = True`` and ``device``: ``step`` then takes a torch tensor of
  actions on that device and every StepResult field is a tensor on it (no numpy round trip).
- optional rl_games attributes: ``value_size`` (default 1), ``get_number_of_agents()`` (1),
  ``use_central_value`` (False), ``has_action_mask()`` (False).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import gymnasium as gym
import numpy as np


@dataclass
class StepResult:
    """What one vectorized step returns (see the module docstring for shapes)."""

    obs: Any
    reward: Any
    terminated: Any
    truncated: Any
    final_obs: Any
    infos: dict = field(default_factory=dict)


class VecEnv(Protocol):
    """A batch of ``num_envs`` environments stepped together."""

    num_envs: int
    observation_space: gym.Space
    action_space: gym.Space

    def reset(self, seed: int | None = None) -> Any: ...

    def step(self, actions: np.ndarray) -> StepResult: ...

    def close(self) -> None: ...
