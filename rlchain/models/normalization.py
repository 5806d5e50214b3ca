"""Running mean / std normalizers for observations and values, saved in checkpoints."""

from __future__ import annotations

from collections.abc import Callable

import torch
import torch.nn as nn


class RunningMeanStd(nn.Module):
    """Tracks mean and variance over batches (Chan et al. parallel update), in float64.

    ``normalize(x)`` -> (x - mean) / sqrt(var + eps), clipped to +-clip when clip > 0;
    ``denormalize(y)`` is its inverse (no clip).
    """

    def __init__(self, shape: tuple[int, ...], epsilon: float = 1e-5, clip: float = 5.0) -> None:
        super().__init__()
        self.epsilon = epsilon
        self.clip = clip
        self.register_buffer("mean", torch.zeros(shape, dtype=torch.float64))
        self.register_buffer("var", torch.ones(shape, dtype=torch.float64))
        self.register_buffer("count", torch.ones((), dtype=torch.float64) * epsilon)
        # (mean, var, n) -> the same over all processes; set under torch.distributed (training/distributed.py)
        self.moment_sync: Callable | None = None

    @torch.no_grad()
    def update(self, x: torch.Tensor) -> None:
        """Fold a batch (N, *shape) into the running statistics."""
        x = x.reshape(-1, *self.mean.shape).double()
        batch_mean = x.mean(0)
        batch_var = x.var(0, unbiased=False)
        n = x.shape[0]
        if self.moment_sync is not None:  # multi_gpu: every rank folds the moments of all ranks' batches
            batch_mean, batch_var, n = self.moment_sync(batch_mean, batch_var, n)
        delta = batch_mean - self.mean
        total = self.count + n
        self.mean += delta * n / total
        m2 = self.var * self.count + batch_var * n + delta.square() * self.count * n / total
        self.var.copy_(m2 / total)
        self.count.copy_(total)

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        y = (x - self.mean.to(x.dtype)) / torch.sqrt(self.var.to(x.dtype) + self.epsilon)
        return y.clamp(-self.clip, self.clip) if self.clip > 0 else y

    def denormalize(self, y: torch.Tensor) -> torch.Tensor:
        return y * torch.sqrt(self.var.to(y.dtype) + self.epsilon) + self.mean.to(y.dtype)
