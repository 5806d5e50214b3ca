"""One Adam optimizer over a model's trainable parameters, with what the Loop needs of an agent."""

from __future__ import annotations

from typing import Any

import torch

from rlchain.algos.core.schedules import scale_lr, set_lr


class AdamAgent:
    """The optimizer of an algorithm that trains one model with Adam (distillation's student, APG's policy),
    with what the Loop's divergence guard and checkpoints need of an agent."""

    def __init__(self, model: torch.nn.Module, lr: float, weight_decay: float) -> None:
        self.params = [p for p in model.parameters() if p.requires_grad]
        self.optimizer = torch.optim.Adam(self.params, lr=lr, weight_decay=weight_decay)

    @property
    def lr(self) -> float:
        """The current learning rate."""
        return self.optimizer.param_groups[0]["lr"]

    def scale_lr(self, factor: float) -> None:
        """Scale the learning rate (the divergence guard's rollback)."""
        scale_lr(self.optimizer, factor)

    def set_lr(self, lr: float) -> None:
        """Set the learning rate (set_params, hyperparam_schedule)."""
        set_lr(self.optimizer, lr)

    def state_dict(self) -> dict[str, Any]:
        """The optimizer's state."""
        return {"optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict`."""
        self.optimizer.load_state_dict(state["optimizer"])
