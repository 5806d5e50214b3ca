"""Pure PPO loss terms, each returning a per-sample tensor (B,) to be averaged by the caller."""

from __future__ import annotations

import torch


def smooth_clamp(x: torch.Tensor, low: float, high: float) -> torch.Tensor:
    """A differentiable clamp: identity inside, tanh-saturating outside (``use_smooth_clamp``)."""
    mid = (high + low) / 2
    half = (high - low) / 2
    return mid + half * torch.tanh((x - mid) / half)


def policy_loss(old_log_probs: torch.Tensor, log_probs: torch.Tensor, advantages: torch.Tensor,
                e_clip: float, smooth: bool = False) -> torch.Tensor:
    """Clipped surrogate: max(-A * r, -A * clip(r, 1 - e, 1 + e)), r = exp(logp - old_logp)."""
    ratio = torch.exp(log_probs - old_log_probs)
    clamp = smooth_clamp if smooth else torch.clamp
    clipped = clamp(ratio, 1.0 - e_clip, 1.0 + e_clip)
    return torch.max(-advantages * ratio, -advantages * clipped)


def value_loss(values: torch.Tensor, old_values: torch.Tensor, returns: torch.Tensor,
               e_clip: float, clip_value: bool) -> torch.Tensor:
    """Squared error to the returns, optionally the max with the clipped-update error (per sample,
    summed over value heads). Shapes (B, V)."""
    loss = (values - returns).square()
    if clip_value:
        clipped = old_values + (values - old_values).clamp(-e_clip, e_clip)
        loss = torch.max(loss, (clipped - returns).square())
    return loss.sum(-1)


def normalize_advantages(advantages: torch.Tensor, eps: float = 1e-8) -> torch.Tensor:
    """Zero mean, unit std over the batch."""
    return (advantages - advantages.mean()) / (advantages.std() + eps)
