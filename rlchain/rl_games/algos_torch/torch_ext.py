"""The parts of rl_games' ``torch_ext`` that observers and scripts use: ``AverageMeter`` and checkpoint I/O."""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

from rlchain.runs import checkpoint as _checkpoint


class AverageMeter(nn.Module):
    """The mean of the last ``max_size`` values (rows of ``in_shape``), as rl_games' observers keep
    game scores: ``update(values)`` adds a batch (N, *in_shape), ``get_mean()`` the mean of what is kept."""

    def __init__(self, in_shape: int | tuple[int, ...], max_size: int) -> None:
        super().__init__()
        self.max_size = int(max_size)
        self.current_size = 0
        self.register_buffer("mean", torch.zeros(in_shape, dtype=torch.float32))

    def update(self, values: torch.Tensor) -> None:
        """Fold a batch of values into the running mean over (at most) the last ``max_size`` values."""
        values = torch.as_tensor(values, dtype=torch.float32, device=self.mean.device)
        size = values.shape[0]
        if size == 0:
            return
        new_mean = values.mean(0)
        size = min(size, self.max_size)
        old = min(self.max_size - size, self.current_size)
        self.current_size = old + size
        self.mean = (self.mean * old + new_mean * size) / self.current_size

    def clear(self) -> None:
        """Forget every value."""
        self.current_size = 0
        self.mean.zero_()

    def __len__(self) -> int:
        return self.current_size

    def get_mean(self) -> Any:
        """The mean as numpy (a scalar for a one-element shape)."""
        mean = self.mean.squeeze(0).cpu().numpy()
        return mean


def load_checkpoint(filename: str, map_location: Any = "cpu") -> dict[str, Any]:
    """Read an rlchain checkpoint (a dict: ``model``, ``optimizer``, counters, ``config``...)."""
    return _checkpoint.load(filename, map_location=map_location)


def save_checkpoint(filename: str, state: dict[str, Any]) -> None:
    """Write ``state`` to ``filename`` (``.pth`` appended when missing, as rl_games does)."""
    if not filename.endswith(".pth"):
        filename += ".pth"
    torch.save(state, filename)


__all__ = ["AverageMeter", "load_checkpoint", "save_checkpoint"]
