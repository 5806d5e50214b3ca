"""Dict observations kept per key: :class:`ObsDict`, a dict of tensors that share leading batch dims.

An env with a ``Dict`` observation space (a camera image beside proprioception) can hand the trainer
its observations as an ObsDict instead of one flattened float vector. Each key keeps its own shape and
dtype (uint8 images stay uint8 in the rollout storage), and the batch operations the rollout, the
storage and the minibatches use act on every key at once: indexing rows (``obs[rows]``, ``obs[idx] =
other``), ``index_select``, ``reshape`` / ``transpose`` of the batch dims, ``clone``, ``detach``, ``to``.

``shape`` is the batch shape only (``(N,)`` for one step of N envs, ``(T, N)`` for a rollout), so code
written for a flat tensor that reads ``obs.shape[0]`` or reshapes the leading dims keeps working; a
string index reads a key (``obs['image']``). Spaces: :func:`is_dict_space` tells which Dict spaces
stay per key, :func:`dict_zeros` preallocates buffers for one. A Discrete (or MultiDiscrete) key is kept
as its integer value (int64, shape ``(*batch,)`` or ``(*batch, *nvec.shape)``), never one-hot and never
normalized: a multi-input network looks it up in an embedding.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

if TYPE_CHECKING:  # torch is imported where it is used: a Ray env worker of numpy envs never needs it
    import torch

CENTRAL_VALUE_KEYS = frozenset({"obs", "state"})


class ObsDict(dict):
    """{key: tensor (*batch, *key_shape)}; ``batch_dims`` leading dims are shared by every key."""

    def __init__(self, items: Mapping[str, torch.Tensor] | None = None, batch_dims: int = 1) -> None:
        super().__init__(items or {})
        self.batch_dims = int(batch_dims)

    # ----- what a flat tensor's callers read ----------------------------------------------------
    @property
    def shape(self) -> torch.Size:
        """The shared batch shape (not a key's full shape)."""
        first = next(iter(self.values()))
        return first.shape[:self.batch_dims]

    @property
    def device(self) -> torch.device:
        return next(iter(self.values())).device

    def dim(self) -> int:
        return self.batch_dims

    # ----- batch operations, applied to every key -----------------------------------------------
    def _map(self, fn: Any, batch_dims: int | None = None) -> ObsDict:
        return ObsDict({k: fn(v) for k, v in self.items()}, self.batch_dims if batch_dims is None else batch_dims)

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, str):
            return super().__getitem__(index)
        out = {k: v[index] for k, v in self.items()}
        first, picked = next(iter(self.values())), next(iter(out.values()))
        return ObsDict(out, picked.dim() - (first.dim() - self.batch_dims))  # the batch dims the index leaves

    def __setitem__(self, index: Any, value: Any) -> None:
        if isinstance(index, str):
            super().__setitem__(index, value)
            return
        for key, buffer in self.items():
            buffer[index] = value[key]

    def clone(self) -> ObsDict:
        return self._map(lambda v: v.clone())

    def detach(self) -> ObsDict:
        return self._map(lambda v: v.detach())

    def to(self, *args: Any, **kwargs: Any) -> ObsDict:
        """Every key moved (a dtype argument would cast images too: only devices are meant here)."""
        return self._map(lambda v: v.to(*args, **kwargs))

    def index_select(self, dim: int, index: torch.Tensor) -> ObsDict:
        if not 0 <= dim < self.batch_dims:
            raise IndexError(f"ObsDict.index_select: dim {dim} is not a batch dim (batch dims {self.batch_dims})")
        return self._map(lambda v: v.index_select(dim, index))

    def reshape(self, *shape: Any) -> ObsDict:
        """New batch dims (``shape`` counts only them; ``-1`` allowed); every key keeps its own shape."""
        # one sequence (a tuple, a list or a torch.Size, which is a tuple) or the dims themselves
        batch = tuple(shape[0]) if len(shape) == 1 and isinstance(shape[0], (tuple, list)) else shape
        return self._map(lambda v: v.reshape(*batch, *v.shape[self.batch_dims:]), len(batch))

    def transpose(self, dim0: int, dim1: int) -> ObsDict:
        if max(dim0, dim1) >= self.batch_dims:
            raise IndexError("ObsDict.transpose: only batch dims")
        return self._map(lambda v: v.transpose(dim0, dim1))

    def flatten(self, start_dim: int = 0, end_dim: int = -1) -> torch.Tensor:
        """Each key's values flattened per batch row and concatenated (keys in order): the flat vector
        (an integer key's values as numbers, not one-hot)."""
        if start_dim != self.batch_dims:
            raise ValueError("ObsDict.flatten: only the per-row flattening (start_dim = batch dims)")
        import torch

        return torch.cat([v.reshape(*v.shape[:self.batch_dims], -1).float() for v in self.values()], -1)

    def numel(self) -> int:
        return sum(v.numel() for v in self.values())


DISCRETE_SPACES = (gym.spaces.Discrete, gym.spaces.MultiDiscrete)
"""Entries kept as integers (int64: an embedding's index, the env's own value, ``start`` included)."""


def keyed_entries(space: gym.spaces.Dict) -> bool:
    """Every entry of the Dict a Box, Discrete or MultiDiscrete: the Dicts that can be kept per key (and that are
    flattened in gymnasium's layout, a Discrete one-hot, when a backend flattens them)."""
    return all(isinstance(s, (gym.spaces.Box, *DISCRETE_SPACES)) for s in space.spaces.values())


def is_dict_space(space: Any) -> bool:
    """A Dict space whose entries are Boxes, Discretes or MultiDiscretes (:func:`keyed_entries`), other than the
    central-value ``{'obs', 'state'}`` layout."""
    return isinstance(space, gym.spaces.Dict) and set(space.spaces) != CENTRAL_VALUE_KEYS and keyed_entries(space)


def is_discrete(space: gym.Space) -> bool:
    """A Discrete or MultiDiscrete entry: stored as int64, never normalized, encoded by an embedding."""
    return isinstance(space, DISCRETE_SPACES)


def discrete_layout(space: gym.spaces.Discrete | gym.spaces.MultiDiscrete) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sizes, starts, offsets), int64, one entry per component (1 for a Discrete): how many values each takes,
    its first value (``start``), and where its one-hot (or its rows of a shared table) begins in gymnasium's
    flattened layout (the sizes of the components before it)."""
    sizes = np.asarray(space.n if isinstance(space, gym.spaces.Discrete) else space.nvec, np.int64)
    starts = np.broadcast_to(np.asarray(space.start, np.int64), sizes.shape).reshape(-1)
    sizes = sizes.reshape(-1)
    return sizes, starts, np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)


def flat_size(space: gym.spaces.Dict) -> int:
    """Values per row of :meth:`ObsDict.flatten` (what a flat-input network gets): every key's element count,
    an integer key counting its values (1 for a Discrete), not a one-hot."""
    return sum(int(np.prod(sub.shape)) for sub in space.spaces.values())


def torch_dtype(space: gym.Space) -> torch.dtype:
    """uint8 for a uint8 Box (images stay bytes), int64 for a Discrete / MultiDiscrete, float32 otherwise."""
    import torch

    if is_discrete(space):
        return torch.int64
    return torch.uint8 if np.dtype(space.dtype) == np.uint8 else torch.float32


def obs_row_bytes(space: gym.Space) -> int:
    """Bytes one observation of ``space`` takes in a rollout or replay buffer: for a Dict kept per key each key
    in its own dtype (uint8, int64 or float32: :func:`torch_dtype`), else its flat size (1 byte a uint8 value, 4
    otherwise)."""
    if is_dict_space(space):
        return sum(int(np.prod(sub.shape)) * torch_dtype(sub).itemsize for sub in space.spaces.values())
    shape = getattr(space, "shape", None)
    size = int(np.prod(shape)) if shape else gym.spaces.flatdim(space)
    return size * (1 if getattr(space, "dtype", None) == np.uint8 else 4)


def dict_zeros(batch: tuple[int, ...], space: gym.spaces.Dict, device: torch.device | str = "cpu") -> ObsDict:
    """Zero buffers (*batch, *shape) for every key of ``space``, each in its :func:`torch_dtype`."""
    import torch

    return ObsDict({k: torch.zeros((*batch, *s.shape), dtype=torch_dtype(s), device=device)
                    for k, s in space.spaces.items()}, len(batch))


def as_obs_dict(obs: Mapping[str, Any], space: gym.spaces.Dict, device: torch.device | str) -> ObsDict:
    """A batch of Dict observations ({key: (N, *shape)} arrays or tensors) as an ObsDict on ``device``,
    each key in its space's dtype (uint8 stays uint8), in the space's key order."""
    import torch

    out = {}
    for key, sub in space.spaces.items():
        value = obs[key]
        dtype = torch_dtype(sub)
        value = value if isinstance(value, torch.Tensor) else torch.as_tensor(np.asarray(value))
        out[key] = value.to(device=device, dtype=dtype)
    return ObsDict(out, 1)


def obs_as_tensor(obs: Any, device: torch.device | str) -> torch.Tensor | ObsDict:
    """A batch of observations on ``device``: a dict (an ObsDict or a gymnasium Dict env's arrays) key by key,
    each key's dtype kept, anything else through ``torch.as_tensor``."""
    import torch

    if isinstance(obs, dict):
        return ObsDict({k: torch.as_tensor(v, device=device) for k, v in obs.items()}, getattr(obs, "batch_dims", 1))
    return torch.as_tensor(obs, device=device)
