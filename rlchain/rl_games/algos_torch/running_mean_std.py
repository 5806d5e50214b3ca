"""rl_games' ``running_mean_std``: running mean and variance of a stream of batches, as a module.

``RunningMeanStd(insize)(x)`` folds ``x`` into the statistics while the module is in training mode, then
returns ``(x - mean) / sqrt(var + eps)`` clamped to +-5 (``denorm=True``: the inverse, after the clamp). The
buffers ``running_mean``, ``running_var`` and ``count`` are named as in rl_games' checkpoints.
"""

from __future__ import annotations

import torch
import torch.nn as nn

CLIP = 5.0


class RunningMeanStd(nn.Module):
    """Statistics over axis 0 (``per_channel``: over every axis but the channel one of (C, ...) inputs)."""

    def __init__(self, insize: tuple[int, ...] | int, epsilon: float = 1e-5, per_channel: bool = False,
                 norm_only: bool = False) -> None:
        super().__init__()
        shape = (insize,) if isinstance(insize, int) else tuple(insize)
        self.insize = shape
        self.epsilon = epsilon
        self.norm_only = norm_only
        self.per_channel = per_channel
        self.axis = [0] + list(range(2, len(shape) + 1)) if per_channel else [0]
        size = (shape[0],) if per_channel else shape
        self.register_buffer("running_mean", torch.zeros(size, dtype=torch.float64))
        self.register_buffer("running_var", torch.ones(size, dtype=torch.float64))
        self.register_buffer("count", torch.ones((), dtype=torch.float64))

    @torch.no_grad()
    def update(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> None:
        """Fold the batch ``x`` (rows selected by ``mask`` when given) into the statistics (parallel variance)."""
        if mask is not None:
            x = x[mask.bool().reshape(-1)]
        x = x.double()
        batch_mean, batch_var = x.mean(self.axis), x.var(self.axis, unbiased=False)
        batch_count = x.numel() / batch_mean.numel()
        total = self.count + batch_count
        delta = batch_mean - self.running_mean
        m2 = self.running_var * self.count + batch_var * batch_count + delta ** 2 * self.count * batch_count / total
        self.running_mean += delta * batch_count / total
        self.running_var.copy_(m2 / total)
        self.count.copy_(total)

    def _view(self, stat: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
        stat = stat.to(like.dtype)
        if self.per_channel:
            return stat.view(stat.shape[0], *([1] * (like.dim() - 2)))
        return stat

    def forward(self, input: torch.Tensor, denorm: bool = False, mask: torch.Tensor | None = None) -> torch.Tensor:
        if self.training and not denorm:
            self.update(input, mask)
        mean, var = self._view(self.running_mean, input), self._view(self.running_var, input)
        std = torch.sqrt(var + self.epsilon)
        if denorm:
            return input.clamp(-CLIP, CLIP) * std + mean
        out = input / std if self.norm_only else (input - mean) / std
        return out.clamp(-CLIP, CLIP)


class RunningMeanStdObs(nn.Module):
    """One :class:`RunningMeanStd` per key of a dict observation (``insize``: {key: shape})."""

    def __init__(self, insize: dict, epsilon: float = 1e-5, per_channel: bool = False, norm_only: bool = False) -> None:
        super().__init__()
        self.running_mean_std = nn.ModuleDict({key: RunningMeanStd(shape, epsilon, per_channel, norm_only)
                                               for key, shape in insize.items()})

    def forward(self, input: dict, denorm: bool = False) -> dict:
        return {key: self.running_mean_std[key](value, denorm) for key, value in input.items()}


__all__ = ["RunningMeanStd", "RunningMeanStdObs"]
