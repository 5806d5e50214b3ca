"""``ray.rllib.utils.spaces.repeated``: RLlib's ``Repeated`` space (a variable-length list of a child space)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np


class Repeated(gym.Space):
    """Up to ``max_len`` items of ``child_space`` (the face's networks do not read it: flatten it in a wrapper)."""

    def __init__(self, child_space: gym.Space, max_len: int) -> None:
        super().__init__()
        self.child_space = child_space
        self.max_len = int(max_len)

    def sample(self, mask: Any = None, probability: Any = None) -> list:
        return [self.child_space.sample() for _ in range(self.np_random.integers(1, self.max_len + 1))]

    def contains(self, x: Any) -> bool:
        return isinstance(x, (list, np.ndarray)) and len(x) <= self.max_len and all(
            self.child_space.contains(c) for c in x)

    def __repr__(self) -> str:
        return f"Repeated({self.child_space}, {self.max_len})"


__all__ = ["Repeated"]
