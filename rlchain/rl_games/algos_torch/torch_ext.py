"""The parts of rl_games' ``torch_ext`` that observers, scripts and user networks use: ``AverageMeter``,
checkpoint I/O, shape and masking helpers."""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

from rlchain.runs import checkpoint as _checkpoint
from rlchain.runs.atomic import write_atomic


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


def load_checkpoint(filename: str, map_location: Any = None) -> dict[str, Any]:
    """What :func:`save_checkpoint` (or rl_games' own) wrote: read as data (tensors, numbers, strings,
    containers, numpy scalars; a file naming other objects is refused unless trusted, see
    :func:`rlchain.runs.checkpoint.read`), torch.compile's ``_orig_mod.`` taken out of every key."""
    print(f"=> loading checkpoint '{filename}'")
    return _strip_compiled(_checkpoint.read(filename, map_location=map_location or "cpu"))


def _strip_compiled(value: Any) -> Any:
    """``value`` with torch.compile's ``_orig_mod.`` taken out of every string key, at any depth (rl_games 2.0
    does the same, so a compiled model's checkpoint loads into an uncompiled one)."""
    if isinstance(value, dict):
        return {(k.replace("_orig_mod.", "") if isinstance(k, str) else k): _strip_compiled(v)
                for k, v in value.items()}
    return value


def save_checkpoint(filename: str, state: dict[str, Any]) -> None:
    """Write ``state`` as it is to ``filename + '.pth'`` (rl_games appends the suffix, always), atomically."""
    print(f"=> saving checkpoint '{filename}.pth'")
    write_atomic(filename + ".pth", lambda fh: torch.save(state, fh), suffix=".pth")


__all__ = ["AverageMeter", "load_checkpoint", "save_checkpoint"]


def shape_whc_to_cwh(shape: tuple[int, ...]) -> tuple[int, ...]:
    """(H, W, C) -> (C, H, W) for a 3-d image shape; other shapes unchanged."""
    return (shape[2], shape[0], shape[1]) if len(shape) == 3 else tuple(shape)


def apply_masks(losses: list[torch.Tensor], mask: torch.Tensor | None = None
                ) -> tuple[list[torch.Tensor], torch.Tensor | None]:
    """Each loss (B, 1) averaged over the rows ``mask`` (B,) keeps (rl_games 2.0: divided by the valid count,
    at least 1), or over all rows; returns (losses, the valid count or None)."""
    if mask is None:
        return [loss.mean() for loss in losses], None
    mask = mask.unsqueeze(1)
    count = mask.sum().clamp(min=1.0)
    return [(loss * mask).sum() / count for loss in losses], count


def get_mean_var_with_masks(values: torch.Tensor, masks: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean and unbiased variance over the rows ``masks`` selects (finite for 0 or 1 selected rows)."""
    count = masks.sum()
    mean = (values * masks).sum() / count.clamp(min=1.0)
    return mean, (((values - mean) ** 2) * masks).sum() / (count - 1.0).clamp(min=1.0)


def policy_kl(p0_mu: torch.Tensor, p0_sigma: torch.Tensor, p1_mu: torch.Tensor, p1_sigma: torch.Tensor,
              reduce: bool = True) -> torch.Tensor:
    """KL(p1 || p0) of diagonal Gaussians summed over the action dims, as rl_games measures it (mean over rows
    when ``reduce``)."""
    kl = (torch.log(p1_sigma / p0_sigma + 1e-5)
          + (p0_sigma ** 2 + (p1_mu - p0_mu) ** 2) / (2.0 * (p1_sigma ** 2 + 1e-5)) - 0.5).sum(-1)
    return kl.mean() if reduce else kl


def explained_variance(y_pred: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """1 - Var[y - y_pred] / Var[y]."""
    return 1 - (y - y_pred).var() / y.var().clamp_min(1e-8)
