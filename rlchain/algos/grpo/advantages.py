"""Pure functions for GRPO's advantages over a time-major rollout (T, N).

EmbodiChain's definition: the discounted return from each step to the end of the rollout without
bootstrapping (restarting after each episode end), a mask that keeps each env's steps up to and including
its first episode end in the rollout, and per step the return normalised within each contiguous group of
``group_size`` envs over the members still alive: (R - mean) / (std + eps), std the population one.
"""

from __future__ import annotations

import torch


def discounted_returns(rewards: torch.Tensor, dones: torch.Tensor, gamma: float) -> torch.Tensor:
    """R_t = r_t + gamma R_{t+1} (1 - done_t), R_T = 0: (T, N) float from rewards (T, N), dones (T, N) bool."""
    returns = torch.zeros_like(rewards, dtype=torch.float32)
    running = torch.zeros_like(rewards[0], dtype=torch.float32)
    not_done = 1.0 - dones.float()
    for t in range(rewards.shape[0] - 1, -1, -1):
        running = rewards[t] + gamma * running * not_done[t]
        returns[t] = running
    return returns


def alive_mask(dones: torch.Tensor, truncate_at_first_done: bool = True) -> torch.Tensor:
    """(T, N) float: 1 up to and including each env's first done in the rollout, 0 after (all ones when
    ``truncate_at_first_done`` is False)."""
    if not truncate_at_first_done:
        return torch.ones_like(dones, dtype=torch.float32)
    ended_before = torch.cumsum(dones.float(), dim=0) - dones.float()  # dones strictly before t
    return (ended_before == 0).float()


def group_advantages(returns: torch.Tensor, mask: torch.Tensor, group_size: int, eps: float = 1e-8) -> torch.Tensor:
    """Per step, ``returns`` normalised within contiguous groups of ``group_size`` envs over the members where
    ``mask`` is 1; masked steps get 0. Shapes (T, N); N divisible by ``group_size``."""
    steps, envs = returns.shape
    if envs % group_size:
        raise ValueError(f"num_envs {envs} is not divisible by group_size {group_size}")
    r = returns.reshape(steps, envs // group_size, group_size)
    m = mask.reshape(steps, envs // group_size, group_size)
    count = m.sum(-1, keepdim=True).clamp(min=1.0)
    mean = (r * m).sum(-1, keepdim=True) / count
    std = (((r - mean) ** 2 * m).sum(-1, keepdim=True) / count).sqrt()
    return ((r - mean) / (std + eps) * m).reshape(steps, envs)


def k3_kl(log_probs: torch.Tensor, ref_log_probs: torch.Tensor) -> torch.Tensor:
    """The k3 estimate of KL(pi || pi_ref) per sample: exp(d) - d - 1 with d = log pi_ref - log pi (>= 0)."""
    d = ref_log_probs - log_probs
    return torch.exp(d) - d - 1.0
