"""Pure functions for returns: GAE with time-outs kept apart from terminations."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

if TYPE_CHECKING:
    from rlchain.config.run import RewardShaperConfig


def gae(rewards: torch.Tensor, values: torch.Tensor, next_values: torch.Tensor,
        terminated: torch.Tensor, dones: torch.Tensor, gamma: float, lam: float
        ) -> tuple[torch.Tensor, torch.Tensor]:
    """Generalized advantage estimation over a rollout.

    Shapes: all (T, N) or (T, N, V). ``next_values[t]`` is V(s_{t+1}) of the *true* next state
    (the final observation when the episode ended at t). ``terminated[t]`` stops bootstrapping
    (a true terminal state); ``dones[t]`` (terminated or truncated) stops the advantage from
    flowing across the episode boundary. Returns (advantages, returns = advantages + values).
    """
    if values.dim() == rewards.dim() + 1:
        rewards = rewards.unsqueeze(-1)
    if terminated.dim() < values.dim():
        terminated = terminated.unsqueeze(-1)
        dones = dones.unsqueeze(-1)
    not_terminal = 1.0 - terminated.float()
    not_done = 1.0 - dones.float()
    deltas = rewards + gamma * next_values * not_terminal - values
    carry = gamma * lam * not_done  # what of A_{t+1} flows back into A_t
    if deltas.device.type == "cpu" and not deltas.requires_grad:
        advantages = torch.from_numpy(_backward_sum(deltas.numpy(), carry.numpy()))
    else:
        advantages = torch.zeros_like(values)
        last = torch.zeros_like(values[0])
        for t in range(values.shape[0] - 1, -1, -1):
            last = deltas[t] + carry[t] * last
            advantages[t] = last
    return advantages, advantages + values


def _backward_sum(deltas: np.ndarray, carry: np.ndarray) -> np.ndarray:
    """A_t = deltas_t + carry_t * A_{t+1} from the last step back, in numpy: the same float32 products and sums
    as the tensor loop (one multiply and one add per step, no fused multiply-add), each step a few times
    cheaper than a tensor op's dispatch (a 2,000-step CPU rollout)."""
    out = np.empty_like(deltas)
    last = np.zeros_like(deltas[0])
    for t in range(deltas.shape[0] - 1, -1, -1):
        last = deltas[t] + carry[t] * last
        out[t] = last
    return out


def next_values_from_rollout(values: torch.Tensor, last_values: torch.Tensor,
                             final_values: torch.Tensor, dones: torch.Tensor) -> torch.Tensor:
    """V(s_{t+1}) for every step: the next stored value, or the value of the final observation
    where the episode ended at t (``final_values[t]``, only read where ``dones[t]``).

    Shapes: values, final_values (T, N, V); last_values (N, V); dones (T, N).
    """
    next_values = torch.cat([values[1:], last_values.unsqueeze(0)], dim=0)
    return torch.where(dones.unsqueeze(-1), final_values, next_values)


def shape_rewards(rewards: torch.Tensor, scale: float, shift: float, min_val: float,
                  max_val: float, log_val: bool = False) -> torch.Tensor:
    """rl_games' reward_shaper: clip((r + shift) * scale, min_val, max_val), then log of it with
    ``log_val`` (the shaped reward must then be > 0: a non-positive one turns non-finite and the
    run's divergence check names it)."""
    out = (rewards + shift) * scale
    if min_val != float("-inf") or max_val != float("inf"):
        out = out.clamp(min_val, max_val)
    return out.log() if log_val else out


def shape_with(rewards: torch.Tensor, shaper: RewardShaperConfig) -> torch.Tensor:
    """:func:`shape_rewards` with the fields of a ``RewardShaperConfig`` (``config.reward_shaper``)."""
    return shape_rewards(rewards, shaper.scale_value, shaper.shift_value, shaper.min_val, shaper.max_val,
                         shaper.log_val)
