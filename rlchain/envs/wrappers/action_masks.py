"""Action masks from gymnasium envs, with rl_games' method names.

An env that restricts its actions defines, on the single (unbatched) env::

    has_action_mask() -> bool             # True: get_action_mask() is meaningful
    get_action_mask() -> np.ndarray       # bool (mask_size,): True = action allowed

``mask_size`` is ``n`` for Discrete(n) and ``sum(nvec)`` for MultiDiscrete / Tuple of Discrete
(the per-dimension masks concatenated, in dimension order). The mask describes the env's
*current* state: after ``reset`` and after every ``step`` (with same-step auto-reset, the first
state of the next episode for envs that just finished).

The vecenv backends batch them: ``VecEnv.has_action_mask()`` and ``VecEnv.get_action_mask()``
-> (num_envs, mask_size) bool. In sync/async gymnasium vector envs every sub-env is wrapped in
:class:`ActionMaskProxy` and queried through ``call``, so an env without the methods answers
False instead of killing an async worker with an AttributeError.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np


class ActionMaskProxy(gym.Wrapper):
    """Gives every sub-env ``has_action_mask`` / ``get_action_mask``, delegating to the env's own."""

    def has_action_mask(self) -> bool:
        try:
            fn = self.env.get_wrapper_attr("has_action_mask")
        except AttributeError:
            return False
        return bool(fn()) if callable(fn) else bool(fn)

    def get_action_mask(self) -> np.ndarray:
        try:
            fn = self.env.get_wrapper_attr("get_action_mask")
        except AttributeError:
            raise AttributeError(f"{self.env} has no get_action_mask()") from None
        return np.asarray(fn(), dtype=bool).reshape(-1)


def stack_masks(masks: Any, num_envs: int) -> np.ndarray:
    """Per-env masks (a sequence or an array) -> (num_envs, mask_size) bool array."""
    out = np.asarray(np.stack([np.asarray(m) for m in masks]) if isinstance(masks, (list, tuple)) else masks)
    return out.astype(bool, copy=False).reshape(num_envs, -1)


def vector_has_action_mask(vector_env: Any, native: bool) -> bool:
    """Whether a gymnasium vector env provides masks (native: the vector env's own method)."""
    if native:
        fn = getattr(vector_env.unwrapped, "has_action_mask", None)
        return bool(fn()) if callable(fn) else False
    return all(vector_env.call("has_action_mask"))


def vector_action_mask(vector_env: Any, native: bool, num_envs: int) -> np.ndarray:
    """(num_envs, mask_size) bool masks of a gymnasium vector env's current states."""
    if native:
        return stack_masks(vector_env.unwrapped.get_action_mask(), num_envs)
    return stack_masks(vector_env.call("get_action_mask"), num_envs)
