"""The agent contract (what the Loop asks of an algorithm's agent) and AdamAgent, which keeps it for an algorithm
that trains one model with Adam (distillation's student, APG's policy, PPO's central value, the REINFORCE
example)."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import torch

from rlchain.algos.core.optimizer_step import StepStats, optimizer_step
from rlchain.algos.core.schedules import LinearSchedule, scale_lr, set_lr
from rlchain.parallel.communicator import SINGLE, Communicator


@runtime_checkable
class Agent(Protocol):
    """An algorithm's agent as the Loop sees it: the optimizer state a checkpoint keeps and the divergence guard
    rolls back (``state_dict`` / ``load_state_dict``), and the learning rate the rollback lowers. AdamAgent,
    PPO's agent, SAC's, DQN's and multi-policy PPO's agents keep it; so can a user's algorithm's."""

    @property
    def lr(self) -> float:
        """The current learning rate (the console line, ``info/last_lr``)."""

    def scale_lr(self, factor: float) -> None:
        """Multiply the learning rate(s) by ``factor`` (the divergence guard's rollback)."""

    def state_dict(self) -> dict[str, Any]:
        """The optimizer state and live values a checkpoint keeps."""

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict`."""


class AdamAgent:
    """One Adam optimizer over ``model``'s trainable parameters, its step (:func:`optimizer_step`, the gradients
    averaged over ``comm``'s ranks) and, with ``lr_schedule: linear``, the learning rate decaying linearly from
    ``lr`` to ``min_lr`` over the run (:meth:`apply_progress`). Keeps the :class:`Agent` contract."""

    def __init__(self, model: torch.nn.Module, lr: float, weight_decay: float = 0.0, comm: Communicator = SINGLE,
                 lr_schedule: str | None = None, min_lr: float = 0.0) -> None:
        self.params = [p for p in model.parameters() if p.requires_grad]
        self.optimizer = torch.optim.Adam(self.params, lr=lr, weight_decay=weight_decay)
        self.comm = comm
        self.schedule = LinearSchedule(lr, min_lr) if lr_schedule == "linear" else None

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

    def live_hyperparams(self) -> dict[str, float]:
        """The live learning rate (``lr_schedule`` and rollbacks change it): what get_params reports."""
        return {"learning_rate": self.lr}

    def set_hyperparam(self, name: str, value: float) -> bool:
        """set_params: a new ``learning_rate`` goes to the optimizer; False, as the run's config keeps every value
        (this one too)."""
        if name == "learning_rate":
            self.set_lr(value)
        return False

    def apply_progress(self, progress: float) -> None:
        """``lr_schedule: linear``: the learning rate at ``progress`` (in [0, 1]) of the run; else nothing."""
        if self.schedule is not None:
            self.set_lr(self.schedule.update(self.lr, progress=progress))

    def step(self, loss: torch.Tensor, max_norm: float | None = None, stats: StepStats | None = None,
             what: str = "the update") -> dict[str, float] | None:
        """One optimizer step on ``loss`` (:func:`optimizer_step`: clipped to ``max_norm``, ``stats`` checked)."""
        return optimizer_step(self.optimizer, loss, params=self.params, max_norm=max_norm, comm=self.comm, stats=stats,
                              what=what)

    def state_dict(self) -> dict[str, Any]:
        """The optimizer's state."""
        return {"optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict`."""
        self.optimizer.load_state_dict(state["optimizer"])


def loss_stats(loss: torch.Tensor, grad_norm: torch.Tensor | None) -> dict[str, float]:
    """A step's statistics when it reports its loss (and the gradients' norm, when measured): what the non-finite
    check reads."""
    if grad_norm is None:
        return {"loss": float(loss)}
    loss_value, norm = torch.stack([loss.detach().float(), grad_norm.detach().float()]).tolist()
    return {"loss": loss_value, "grad_norm": norm}
