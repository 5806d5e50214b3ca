"""rl_games' ``running_mean_std``: running mean and variance of a stream of batches, as a module.

``RunningMeanStd(insize)(x)`` folds ``x`` into the statistics while the module is in training mode, then
returns ``(x - mean) / sqrt(var + eps)`` clamped to +-5 (``denorm=True``: the inverse, after the clamp). The
buffers ``running_mean``, ``running_var`` and ``count`` are named as in rl_games' checkpoints, and both classes
compile with ``torch.jit.script`` as rl_games' models script them.
"""

import torch
import torch.nn as nn

CLIP = 5.0  # rl_games' clamp, in standard deviations


class RunningMeanStd(nn.Module):
    """Statistics over the batch axis (``per_channel``: per channel of (B, C, ...) inputs, over every other axis).
    They start from one pseudo-sample of mean 0 and variance 1, as rl_games' do."""

    def __init__(self, insize, epsilon: float = 1e-5, per_channel: bool = False, norm_only: bool = False) -> None:
        super().__init__()
        shape = (int(insize),) if isinstance(insize, int) else tuple(int(s) for s in insize)
        self.insize: list[int] = list(shape)
        self.epsilon = float(epsilon)
        self.norm_only = norm_only
        self.clip: float = CLIP
        self.per_channel = per_channel
        self.axis: list[int] = [0] + list(range(2, len(shape) + 1)) if per_channel else [0]
        size = (shape[0],) if per_channel else shape
        self.register_buffer("running_mean", torch.zeros(size, dtype=torch.float64))
        self.register_buffer("running_var", torch.ones(size, dtype=torch.float64))
        self.register_buffer("count", torch.ones((), dtype=torch.float64))

    def update(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> None:
        """Fold the batch ``x`` (rows selected by ``mask`` when given) into the statistics (parallel variance)."""
        with torch.no_grad():
            if mask is not None:
                x = x[mask.reshape(-1) > 0]
            x = x.double()
            batch_mean = x.mean(self.axis)
            batch_var = x.var(self.axis, unbiased=False)
            batch_count = float(x.numel() // max(batch_mean.numel(), 1))
            total = self.count + batch_count
            delta = batch_mean - self.running_mean
            m2 = self.running_var * self.count + batch_var * batch_count \
                + delta * delta * self.count * batch_count / total
            self.running_mean.add_(delta * batch_count / total)
            self.running_var.copy_(m2 / total)
            self.count.copy_(total)

    def _stat(self, stat: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
        """A statistic in ``like``'s dtype, shaped to broadcast over it (per channel: (1, C, 1, ...))."""
        stat = stat.to(like.dtype)
        if self.per_channel:
            shape = [1] * like.dim()
            shape[1] = stat.shape[0]
            return stat.view(shape)
        return stat

    def forward(self, input: torch.Tensor, denorm: bool = False, mask: torch.Tensor | None = None) -> torch.Tensor:
        if self.training and not denorm:
            self.update(input, mask)
        mean = self._stat(self.running_mean, input)
        std = torch.sqrt(self._stat(self.running_var, input) + self.epsilon)
        if denorm:
            return input.clamp(-self.clip, self.clip) * std + mean
        if self.norm_only:
            return input / std
        return ((input - mean) / std).clamp(-self.clip, self.clip)


class RunningMeanStdObs(nn.Module):
    """One :class:`RunningMeanStd` per key of a dict observation (``insize``: {key: shape}); the input must
    carry exactly those keys."""

    def __init__(self, insize: dict, epsilon: float = 1e-5, per_channel: bool = False, norm_only: bool = False) -> None:
        super().__init__()
        if not isinstance(insize, dict):
            raise ValueError(f"RunningMeanStdObs: expected {{key: shape}}, got {type(insize).__name__}")
        self.running_mean_std = nn.ModuleDict({key: RunningMeanStd(shape, epsilon, per_channel, norm_only)
                                               for key, shape in insize.items()})

    def forward(self, input: dict[str, torch.Tensor], denorm: bool = False) -> dict[str, torch.Tensor]:
        if len(input) != len(self.running_mean_std):
            raise ValueError("observation dict keys do not match the normalizer keys")
        out: dict[str, torch.Tensor] = {}
        for key, module in self.running_mean_std.items():
            out[key] = module(input[key], denorm)
        return out


__all__ = ["RunningMeanStd", "RunningMeanStdObs"]
