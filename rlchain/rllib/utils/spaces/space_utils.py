"""``ray.rllib.utils.spaces.space_utils``: ``flatten_space`` and ``batch``, as RLlib's example envs call them."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np


def flatten_space(space: gym.Space) -> list[gym.Space]:
    """The primitive spaces of a (nested) Tuple / Dict space, in RLlib's order (Dict keys sorted)."""
    if isinstance(space, gym.spaces.Tuple):
        return [s for sub in space.spaces for s in flatten_space(sub)]
    if isinstance(space, gym.spaces.Dict):
        return [s for key in sorted(space.spaces) for s in flatten_space(space.spaces[key])]
    return [space]


def batch(items: list[Any], individual_items_already_have_batch_dim: bool = False) -> Any:
    """Stack a list of (nested dict / tuple) structures into one structure of arrays."""
    first = items[0]
    if isinstance(first, dict):
        return {k: batch([item[k] for item in items], individual_items_already_have_batch_dim) for k in first}
    if isinstance(first, tuple):
        return tuple(batch([item[i] for item in items], individual_items_already_have_batch_dim)
                     for i in range(len(first)))
    arrays = [np.asarray(item) for item in items]
    return np.concatenate(arrays) if individual_items_already_have_batch_dim else np.stack(arrays)


__all__ = ["batch", "flatten_space"]
