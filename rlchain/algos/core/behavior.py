"""Pure behaviour-cloning losses for distillation: a student's action distribution against a teacher's.

Every function takes the distribution object both policies share (:mod:`rlchain.models.distributions`)
and their parameters (B, param_size); the action-space differences stay in the distribution's methods
(``mode``, ``kl``, ``log_prob``). Each returns a per-sample loss (B,) for the caller to average.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F


def resolve_loss(kind: str, continuous: bool) -> str:
    """``auto`` -> ``mse`` for continuous actions, ``kl`` otherwise; any other kind as given. ``mse`` and
    ``huber`` compare action means: they need continuous actions (ValueError otherwise)."""
    if kind == "auto":
        return "mse" if continuous else "kl"
    if kind in ("mse", "huber") and not continuous:
        raise ValueError(f"loss {kind} compares continuous action means; this policy's actions are discrete "
                         f"(use kl or cross_entropy)")
    return kind


def behavior_loss(dist: Any, student: torch.Tensor, teacher: torch.Tensor, kind: str,
                  huber_delta: float = 1.0) -> torch.Tensor:
    """Per-sample (B,) loss of the student's params against the teacher's (both (B, param_size), already
    masked where action masks apply: masked actions then carry no probability on either side).

    mse / huber: on the action means (``dist.mode``), summed over action dimensions; kl: KL(teacher ||
    student); cross_entropy: -log p_student(teacher's mode action)."""
    if kind in ("mse", "huber"):
        s, t = dist.mode(student), dist.mode(teacher).detach()
        per = F.mse_loss(s, t, reduction="none") if kind == "mse" else \
            F.huber_loss(s, t, reduction="none", delta=huber_delta)
        return per.reshape(per.shape[0], -1).sum(-1)
    if kind == "kl":
        return dist.kl(teacher.detach(), student)
    if kind == "cross_entropy":
        return -dist.log_prob(student, dist.mode(teacher).detach())
    raise ValueError(f"unknown behaviour loss '{kind}' (mse, huber, kl, cross_entropy)")
