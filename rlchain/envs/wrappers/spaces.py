"""Small array/space adapters shared by the vecenv backends.

Every backend hands the trainer the same dtypes: observations float32 (uint8 images stay
uint8), rewards float32, terminated/truncated bool, and takes actions in the dtype the
underlying env expects (integers for discrete spaces, the Box dtype for continuous ones).
"""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.envs.obs_dict import DISCRETE_SPACES, discrete_layout, keyed_entries
from rlchain.envs.wrappers.action_masks import ActionMaskProxy
from rlchain.envs.wrappers.central_value import concat_obs_state_env
from rlchain.envs.wrappers.dict_obs import FlatDictBox, flatten_dict_env
from rlchain.envs.wrappers.gym_state import StateUnavailable, restore, snapshot

KEPT_OBS_DTYPES = (np.dtype(np.float32), np.dtype(np.uint8))


def float32_obs_space(space: gym.Space) -> gym.Space:
    """The observation space as the trainer sees it: a non-uint8 Box becomes a float32 Box.

    A Dict space (DeepMind Control through envpool) becomes the flat float32 Box that
    :func:`flatten_dict_obs` produces. Other spaces are returned unchanged.
    """
    if isinstance(space, gym.spaces.Dict):  # flattened in key order; the parts stay named (dict_space)
        if keyed_entries(space):  # Box, Discrete and MultiDiscrete entries: gymnasium's layout (one-hot)
            return FlatDictBox(space, np.float32)
        size = sum(int(np.prod(s.shape)) for s in space.spaces.values())
        return gym.spaces.Box(-np.inf, np.inf, (size,), np.float32)
    if isinstance(space, FlatDictBox) and space.dtype not in KEPT_OBS_DTYPES:
        return FlatDictBox(space.dict_space, np.float32)  # keeps the Dict for the network
    if isinstance(space, gym.spaces.Box) and space.dtype not in KEPT_OBS_DTYPES:
        return _float32_box(space)
    return space


def float32_action_space(space: gym.Space) -> gym.Space:
    """The action space as the trainer sees it: a float64 Box becomes float32 (same bounds)."""
    if isinstance(space, gym.spaces.Box) and space.dtype == np.float64:
        return _float32_box(space)
    return space


def _float32_box(space: gym.spaces.Box) -> gym.spaces.Box:
    """``space`` as a float32 Box of the same bounds."""
    with warnings.catch_warnings():  # "precision lowered by casting to float32": intended
        warnings.simplefilter("ignore")
        return gym.spaces.Box(space.low.astype(np.float32), space.high.astype(np.float32), space.shape, np.float32)


def flatten_dict_obs(obs: dict[str, np.ndarray], space: gym.spaces.Dict) -> np.ndarray:
    """Concatenate a batched dict observation {key: (N, ...)} into (N, total) in space key order: for a Dict of
    Box, Discrete and MultiDiscrete entries gymnasium's layout (``gym.spaces.flatten``: a Discrete one-hot, the
    :class:`FlatDictBox` :func:`float32_obs_space` declares), else every entry's values raveled."""
    one_hot = keyed_entries(space)
    return np.concatenate([batch_one_hot(np.asarray(obs[k]), sub) if one_hot and isinstance(sub, DISCRETE_SPACES)
                           else np.asarray(obs[k]).reshape(len(obs[k]), -1) for k, sub in space.spaces.items()],
                          axis=1)


def batch_one_hot(values: np.ndarray, space: gym.spaces.Discrete | gym.spaces.MultiDiscrete) -> np.ndarray:
    """(N,) or (N, *nvec.shape) integer values -> (N, sum of sizes) float32 one-hots, as ``gym.spaces.flatten``
    lays out one value (``start`` subtracted)."""
    sizes, starts, offsets = discrete_layout(space)
    rows = values.reshape(len(values), -1).astype(np.int64) - starts + offsets
    out = np.zeros((len(values), int(sizes.sum())), np.float32)
    np.put_along_axis(out, rows, 1.0, axis=1)
    return out


def cast_obs(obs: np.ndarray) -> np.ndarray:
    """(N, *obs_shape) observations as float32, uint8 kept as it is; no copy when already right."""
    obs = np.asarray(obs)
    return obs if obs.dtype in KEPT_OBS_DTYPES else obs.astype(np.float32)


def cast_actions(actions: np.ndarray, space: gym.Space, num_envs: int) -> np.ndarray:
    """Actions (N, *action_shape) in the dtype ``space`` (the single-env space) wants.

    Accepts torch tensors and (N, 1) columns for discrete spaces; integer dtypes for Discrete
    and MultiDiscrete, the Box dtype for Box; a Tuple of Discrete gets a tuple of K (N,) arrays.
    """
    if hasattr(actions, "detach"):  # a torch tensor
        actions = actions.detach().cpu().numpy()
    actions = np.asarray(actions)
    if isinstance(space, gym.spaces.Discrete):
        return actions.reshape(num_envs).astype(np.int64, copy=False)
    if isinstance(space, (gym.spaces.Box, gym.spaces.MultiDiscrete, gym.spaces.MultiBinary)):
        return actions.reshape((num_envs, *space.shape)).astype(space.dtype, copy=False)
    if isinstance(space, gym.spaces.Tuple):  # Tuple of Discrete: (N, K) -> K arrays (N,), as gymnasium batches it
        columns = actions.reshape(num_envs, len(space.spaces)).astype(np.int64, copy=False)
        return tuple(columns[:, i] for i in range(len(space.spaces)))
    return actions


def step_arrays(reward: np.ndarray, terminated: np.ndarray,
                truncated: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reward (N,) float32 and terminated / truncated (N,) bool from whatever the backend gave."""
    return (np.asarray(reward, dtype=np.float32).reshape(-1),
            np.asarray(terminated, dtype=bool).reshape(-1),
            np.asarray(truncated, dtype=bool).reshape(-1))


class EnvIndexError(RuntimeError):
    """An exception raised inside sub-env ``index``, re-raised with the index in its message."""


class IndexedErrors(gym.Wrapper):
    """Tags any exception from ``reset``/``step`` with the sub-env's index (survives async workers,
    which re-raise in the main process with the exception type and message only)."""

    def __init__(self, env: gym.Env, index: int) -> None:
        super().__init__(env)
        self.index = index

    def reset(self, **kwargs: Any) -> Any:
        try:
            return self.env.reset(**kwargs)
        except Exception as exc:
            raise EnvIndexError(f"env {self.index} reset raised {type(exc).__name__}: {exc}") from exc

    def step(self, action: Any) -> Any:
        try:
            return self.env.step(action)
        except Exception as exc:
            raise EnvIndexError(f"env {self.index} step raised {type(exc).__name__}: {exc}") from exc

    @property
    def rlchain_state(self) -> Any:
        """This sub-env's whole state (:func:`rlchain.envs.wrappers.gym_state.snapshot`): read with the
        vector env's ``get_attr``, written with ``set_attr`` (in the worker, for async envs).
        A :class:`~rlchain.envs.wrappers.gym_state.StateUnavailable` is returned, not raised, so the
        reason crosses an async worker's pipe intact."""
        try:
            return snapshot(self.env, f"env {self.index}")
        except StateUnavailable as exc:
            return exc

    @rlchain_state.setter
    def rlchain_state(self, state: Any) -> None:
        restore(self.env, state, f"env {self.index}")


def make_indexed(env_id: str, index: int, kwargs: dict) -> gym.Env:
    """``gym.make(env_id, **kwargs)`` wrapped so its errors name ``index`` (picklable for async),
    Dict observations flattened and action-mask methods always present (see action_masks.py)."""
    return wrap_indexed(gym.make(env_id, **kwargs), index)


def wrap_indexed(env: gym.Env, index: int) -> gym.Env:
    """``env`` as :func:`make_indexed` wraps the env it makes."""
    return IndexedErrors(ActionMaskProxy(concat_obs_state_env(flatten_dict_env(env))), index)


def call_indexed(make: Any, index: int) -> gym.Env:
    """``make()`` (a zero-argument env factory) wrapped as :func:`make_indexed` wraps the env it makes."""
    return wrap_indexed(make(), index)
