"""IMPALA's learner: the PPO agent (optimizer, lr schedules, value and entropy losses) with V-trace's
policy gradient instead of the clipped surrogate."""

from __future__ import annotations

import torch

from rlchain.algos.core.losses import vtrace_policy_loss
from rlchain.algos.ppo.agent import PPOAgent


def vtrace_surrogate(old_log_probs: torch.Tensor, log_probs: torch.Tensor, advantages: torch.Tensor,
                     e_clip: float, smooth: bool) -> torch.Tensor:
    """V-trace's policy gradient loss (B,): the ratio clip is inside the advantages, so ``e_clip`` and
    ``smooth`` are not read."""
    return vtrace_policy_loss(log_probs, advantages)


class ImpalaAgent(PPOAgent):
    """Trains on batches whose advantages are V-trace's ``pg_advantages`` (the ratio clip is inside them)."""

    surrogate = staticmethod(vtrace_surrogate)
