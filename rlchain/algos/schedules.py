"""Learning-rate schedules: constant, linear decay and rl_games' adaptive KL rule."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class ConstantSchedule:
    """Keeps the learning rate."""

    def update(self, lr: float, kl: float | None = None, progress: float | None = None) -> float:
        return lr


@dataclass
class AdaptiveKLSchedule:
    """lr / 1.5 when KL > 2 * threshold, lr * 1.5 when KL < threshold / 2, within [min_lr, max_lr]."""

    kl_threshold: float
    min_lr: float = 1e-6
    max_lr: float = 1e-2

    def update(self, lr: float, kl: float | None = None, progress: float | None = None) -> float:
        if kl is None:
            return lr
        if kl > 2.0 * self.kl_threshold:
            lr = max(lr / 1.5, self.min_lr)
        elif kl < 0.5 * self.kl_threshold:
            lr = min(lr * 1.5, self.max_lr)
        return lr


@dataclass
class LinearSchedule:
    """lr = min_lr + (start_lr - min_lr) * (1 - progress), progress in [0, 1] of max_epochs/max_frames."""

    start_lr: float
    min_lr: float = 0.0

    def update(self, lr: float, kl: float | None = None, progress: float | None = None) -> float:
        if progress is None:
            return lr
        return self.min_lr + (self.start_lr - self.min_lr) * max(0.0, 1.0 - progress)


def make_schedule(name: str | None, learning_rate: float, kl_threshold: float, min_lr: float,
                  max_lr: float) -> ConstantSchedule | AdaptiveKLSchedule | LinearSchedule:
    """The schedule named by ``lr_schedule``."""
    if name == "adaptive":
        return AdaptiveKLSchedule(kl_threshold, min_lr, max_lr)
    if name == "linear":
        return LinearSchedule(learning_rate, min_lr)
    return ConstantSchedule()
