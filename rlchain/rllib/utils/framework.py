"""``ray.rllib.utils.framework``: ``try_import_torch`` (rlchain is PyTorch only)."""

from __future__ import annotations

from typing import Any


def try_import_torch(error: bool = False) -> tuple[Any, Any]:
    """(torch, torch.nn), as RLlib's helper returns them."""
    import torch
    return torch, torch.nn


def try_import_tf(error: bool = False) -> tuple[None, None, None]:
    """(None, None, None): rlchain has no TensorFlow (RLlib returns that when TF is not installed)."""
    if error:
        raise ImportError("rlchain is PyTorch only: no TensorFlow")
    return None, None, None


__all__ = ["try_import_tf", "try_import_torch"]
