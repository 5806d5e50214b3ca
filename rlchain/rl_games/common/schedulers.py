"""rl_games' ``common.schedulers``: learning-rate (and entropy) schedules with rl_games' ``update`` call.

``update(current_lr, entropy_coef, epoch, frames, kl_dist, **kwargs)`` returns ``(lr, entropy_coef)``. rlchain's
own loop schedules through its config (``lr_schedule``); these serve user code written against rl_games.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rlchain.algos.core.schedules import AdaptiveKLSchedule


class RLScheduler:
    """The interface: ``update`` returns the next (lr, entropy_coef)."""

    def update(self, current_lr: float, entropy_coef: float, epoch: int, frames: int, **kwargs: Any
               ) -> tuple[float, float] | None:
        return None


class IdentityScheduler(RLScheduler):
    """Keeps both values."""

    def update(self, current_lr: float, entropy_coef: float, epoch: int, frames: int, kl_dist: Any = None,
               **kwargs: Any) -> tuple[float, float]:
        return current_lr, entropy_coef


@dataclass
class AdaptiveScheduler(AdaptiveKLSchedule, RLScheduler):
    """KL-adaptive (rlchain's :class:`~rlchain.algos.core.schedules.AdaptiveKLSchedule`): lr / ``lr_multiplier``
    when the KL exceeds twice ``kl_threshold`` (not below ``min_lr``), lr * ``lr_multiplier`` when it is under half
    of it (not above ``max_lr``)."""

    kl_threshold: float = 0.008
    __hash__ = object.__hash__  # hashable, as rl_games' scheduler is

    def update(self, current_lr: float, entropy_coef: float, epoch: int, frames: int, kl_dist: Any = 0.0,
               **kwargs: Any) -> tuple[float, float]:
        return AdaptiveKLSchedule.update(self, current_lr, kl_dist), entropy_coef


class LinearScheduler(RLScheduler):
    """From ``start_lr`` down to ``min_lr`` over ``max_steps`` epochs (``use_epochs``) or frames; with
    ``apply_to_entropy`` the entropy coefficient likewise, from ``start_entropy_coef`` to ``min_entropy_coef``."""

    def __init__(self, start_lr: float, min_lr: float = 1e-6, max_steps: int = 1000000, use_epochs: bool = True,
                 apply_to_entropy: bool = False, **kwargs: Any) -> None:
        self.start_lr = start_lr
        self.min_lr = min_lr
        self.max_steps = max_steps
        self.use_epochs = use_epochs
        self.apply_to_entropy = apply_to_entropy
        if apply_to_entropy:
            self.start_entropy_coef = kwargs.pop("start_entropy_coef", 0.01)
            self.min_entropy_coef = kwargs.pop("min_entropy_coef", 0.0001)

    def update(self, current_lr: float, entropy_coef: float, epoch: int, frames: int, kl_dist: Any = None,
               **kwargs: Any) -> tuple[float, float]:
        steps = epoch if self.use_epochs else frames
        left = max(0, self.max_steps - steps) / self.max_steps  # rl_games' arithmetic, to the last bit
        lr = self.min_lr + (self.start_lr - self.min_lr) * left
        if self.apply_to_entropy:
            entropy_coef = self.min_entropy_coef + (self.start_entropy_coef - self.min_entropy_coef) * left
        return lr, entropy_coef


__all__ = ["RLScheduler", "IdentityScheduler", "AdaptiveScheduler", "LinearScheduler"]
