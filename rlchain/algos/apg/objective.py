"""Pure function for APG's objective over one segment of differentiable steps."""

from __future__ import annotations

import torch


def discounted_segment_return(rewards: list[torch.Tensor], dones: list[torch.Tensor], gamma: float,
                              discount: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """sum_t d_t r_t per env, d_0 = ``discount`` (ones by default), d_{t+1} = 1 after an episode end at t, else
    gamma d_t. ``rewards`` / ``dones``: per step (N,) tensors (rewards keep their graph). Returns the (N,)
    return and the discount the next segment starts with."""
    d = torch.ones_like(rewards[0]) if discount is None else discount
    total = torch.zeros_like(rewards[0])
    for r, done in zip(rewards, dones):
        total = total + d * r
        d = torch.where(done, torch.ones_like(d), d * gamma)
    return total, d.detach()
