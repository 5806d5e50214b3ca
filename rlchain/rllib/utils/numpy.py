"""``ray.rllib.utils.numpy``: the numpy helpers RLlib's inference examples call on a module's outputs."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

SMALL_NUMBER = 1e-6
LARGE_INTEGER = 100_000_000


def convert_to_numpy(x: Any, reduce_type: bool = True) -> Any:
    """``x`` with every tensor a numpy array (dicts, lists and tuples kept as they are); with ``reduce_type``
    float64 becomes float32, as RLlib's does."""
    if isinstance(x, dict):
        return {k: convert_to_numpy(v, reduce_type) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return type(x)(convert_to_numpy(v, reduce_type) for v in x)
    if isinstance(x, torch.Tensor):
        x = x.detach().cpu().numpy()
    if reduce_type and isinstance(x, np.ndarray) and x.dtype == np.float64:
        x = x.astype(np.float32)
    return x


def softmax(x: Any, axis: int = -1, epsilon: float | None = None) -> np.ndarray:
    """The softmax of ``x`` along ``axis``, each probability at least ``epsilon`` (1e-6) before normalizing."""
    x = np.asarray(convert_to_numpy(x))
    shifted = np.exp(x - np.max(x, axis=axis, keepdims=True))
    shifted = np.maximum(shifted, SMALL_NUMBER if epsilon is None else epsilon)
    return shifted / np.sum(shifted, axis=axis, keepdims=True)


def one_hot(x: Any, depth: int = 0, on_value: float = 1.0, off_value: float = 0.0,
            dtype: Any = np.float32) -> np.ndarray:
    """``x``'s integers as one-hot rows of ``depth`` (the largest value + 1 when 0)."""
    x = np.asarray(convert_to_numpy(x)).astype(np.int64)
    depth = int(depth) or int(x.max()) + 1
    out = np.full((*x.shape, depth), off_value, dtype=dtype)
    np.put_along_axis(out, x[..., None], on_value, axis=-1)
    return out


__all__ = ["LARGE_INTEGER", "SMALL_NUMBER", "convert_to_numpy", "one_hot", "softmax"]
