"""Pure PPO loss terms, each returning a per-sample tensor (B,) to be averaged by the caller,
and the check of a network's auxiliary losses (``get_aux_loss()``, already reduced to scalars)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch

from rlchain.errors import NetworkError

BUILTIN_LOSS_TAGS = frozenset({"a_loss", "c_loss", "entropy", "bounds_loss"})
"""``losses/<name>`` tags PPO writes itself; an auxiliary loss may not take one of these names."""


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


def aux_loss_terms(raw: Any) -> dict[str, torch.Tensor]:
    """A network's ``get_aux_loss()`` result, checked: ``{name: 0-d float tensor}``.

    rl_games' contract: ``None`` (no auxiliary loss) or a dict of scalar losses, each added to the
    PPO loss with weight 1 (the network scales its own) and logged as ``losses/<name>``. A ``None``
    entry means no loss this step. Anything else raises a one-line NetworkError naming the key.
    """
    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise NetworkError(f"get_aux_loss() must return a dict of scalar tensors or None, got "
                           f"{type(raw).__name__}")
    out: dict[str, torch.Tensor] = {}
    for name, value in raw.items():
        where = f"get_aux_loss()[{name!r}]"
        if value is None:
            continue
        if not isinstance(name, str) or not name:
            raise NetworkError(f"{where}: loss names must be non-empty strings (logged as losses/<name>)")
        if name in BUILTIN_LOSS_TAGS:
            raise NetworkError(f"{where}: the name collides with PPO's own losses/{name} tag; rename the loss")
        if not isinstance(value, torch.Tensor):
            raise NetworkError(f"{where} must be a scalar tensor, got {type(value).__name__} {value!r}")
        if value.numel() != 1:
            raise NetworkError(f"{where} must be a scalar tensor, got shape {tuple(value.shape)} "
                               f"(reduce it, e.g. with .mean())")
        if not value.is_floating_point():
            raise NetworkError(f"{where} must be a floating-point tensor, got {value.dtype}")
        out[name] = value.reshape(())
    return out


def vtrace_policy_loss(old_log_probs: torch.Tensor, log_probs: torch.Tensor, pg_advantages: torch.Tensor,
                       e_clip: float = 0.0, smooth: bool = False) -> torch.Tensor:
    """IMPALA's policy-gradient loss per sample: -log pi(a|s) * min(rho-bar, pi/mu) * (q - V), the
    advantage being V-trace's ``pg_advantages`` (a constant here). :func:`policy_loss`'s signature, so PPO's agent
    takes it as its surrogate (IMPALA): the ratio clip is inside the advantages, ``old_log_probs``, ``e_clip`` and
    ``smooth`` are not read."""
    return -log_probs * pg_advantages.detach()


def policy_loss_grad(ratio: torch.Tensor, advantages: torch.Tensor, losses: torch.Tensor) -> torch.Tensor:
    """d :func:`policy_loss` / d log_probs per sample (B,), given the ratio r = exp(logp - old_logp) and the
    loss's values ``losses`` (no smooth clamp): the unclipped term's -A * r where the max took it (a tie, r
    inside the clip range, counts as taken), else 0 (the clipped term is flat in r outside the range)."""
    unclipped = -advantages * ratio
    return torch.where(losses == unclipped, unclipped, 0.0)


def value_loss_grad(values: torch.Tensor, old_values: torch.Tensor, returns: torch.Tensor,
                    e_clip: float, clip_value: bool) -> torch.Tensor:
    """d :func:`value_loss` / d values (B, V); with ``clip_value`` the larger error's derivative, a tie's split
    evenly between both (as autograd's max does); the clipped error is flat where the update was clipped."""
    error = values - returns
    grad = 2.0 * error
    if not clip_value:
        return grad
    step = values - old_values
    clipped_error = old_values + step.clamp(-e_clip, e_clip) - returns
    grad_clipped = (2.0 * clipped_error).mul_((step >= -e_clip) & (step <= e_clip))
    loss, loss_clipped = error.square(), clipped_error.square()
    tie = 0.5 * (grad + grad_clipped)
    return torch.where(loss > loss_clipped, grad, torch.where(loss < loss_clipped, grad_clipped, tie))
