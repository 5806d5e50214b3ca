"""Learning-rate and entropy schedules: constant, linear and polynomial decay, rl_games' adaptive KL rule.

The decays are pure functions of ``progress``, the fraction of the run done (epochs over
``max_epochs``, else frames over ``max_frames``); the schedule classes wrap them for the agent.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol


class _HasParamGroups(Protocol):
    param_groups: list[dict]


def set_lr(optimizer: _HasParamGroups, lr: float) -> None:
    """Give every parameter group of ``optimizer`` the learning rate ``lr`` (schedules, set_params)."""
    for group in optimizer.param_groups:
        group["lr"] = float(lr)


def scale_lr(optimizer: _HasParamGroups, factor: float) -> None:
    """Multiply every parameter group's learning rate by ``factor`` (the divergence guard's rollback)."""
    for group in optimizer.param_groups:
        group["lr"] *= factor

MIN_ENTROPY_COEF = 1e-4
"""Where ``schedule_entropy`` ends: rl_games' LinearScheduler ``min_entropy_coef``, not configurable there."""


def polynomial_decay(start: float, end: float, progress: float, power: float = 1.0) -> float:
    """``end + (start - end) * (1 - progress) ** power``, with ``progress`` clamped to [0, 1].

    ``power`` 1 is a linear decay; progress 0 gives ``start``, progress 1 (and beyond) ``end``.
    """
    remaining = 1.0 - min(max(progress, 0.0), 1.0)
    return end + (start - end) * remaining ** power


def linear_decay(start: float, end: float, progress: float) -> float:
    """``end + (start - end) * (1 - progress)``, progress clamped to [0, 1] (rl_games' LinearScheduler)."""
    return polynomial_decay(start, end, progress, 1.0)


def scheduled_entropy_coef(start: float, progress: float, end: float = MIN_ENTROPY_COEF) -> float:
    """``schedule_entropy``: the entropy coefficient moves linearly from ``start`` (the config's
    ``entropy_coef``) to ``end`` (1e-4) over the run, alongside the linear learning rate.

    As in rl_games it is the same formula whatever ``start`` is: a start below 1e-4 rises to it.
    """
    return linear_decay(start, end, progress)


@dataclass
class ConstantSchedule:
    """Keeps the learning rate."""

    def update(self, lr: float, kl: float | None = None, progress: float | None = None) -> float:
        return lr


@dataclass
class AdaptiveKLSchedule:
    """lr / m when KL > 2 * threshold, lr * m when KL < threshold / 2, within [min_lr, max_lr]
    (m = ``lr_multiplier``, 1.5 as in rl_games)."""

    kl_threshold: float
    min_lr: float = 1e-6
    max_lr: float = 1e-2
    lr_multiplier: float = 1.5

    def update(self, lr: float, kl: float | None = None, progress: float | None = None) -> float:
        if kl is None:
            return lr
        if kl > 2.0 * self.kl_threshold:
            lr = max(lr / self.lr_multiplier, self.min_lr)
        elif kl < 0.5 * self.kl_threshold:
            lr = min(lr * self.lr_multiplier, self.max_lr)
        return lr


@dataclass
class LinearSchedule:
    """lr = min_lr + (start_lr - min_lr) * (1 - progress), progress in [0, 1] of max_epochs/max_frames."""

    start_lr: float
    min_lr: float = 0.0

    def update(self, lr: float, kl: float | None = None, progress: float | None = None) -> float:
        if progress is None:
            return lr
        return linear_decay(self.start_lr, self.min_lr, progress)


@dataclass
class PolynomialSchedule:
    """``polynom_decay``: lr = min_lr + (start_lr - min_lr) * (1 - progress) ** power.

    rl_games' TensorFlow agent read ``lr_schedule: polynom_decay`` this way, with the exponent
    ``decay_power`` (default 1), over ``max_epochs``; its torch agent (1.6.5) keeps such an lr
    constant. Two differences from the TensorFlow agent: its floor was learning_rate / 1000 (set
    ``min_lr`` to that for the same curve), and it shrank ``e_clip`` by the same factor (rlchain
    keeps ``e_clip``, as rl_games' torch agent does).
    """

    start_lr: float
    min_lr: float = 0.0
    power: float = 1.0

    def update(self, lr: float, kl: float | None = None, progress: float | None = None) -> float:
        if progress is None:
            return lr
        return polynomial_decay(self.start_lr, self.min_lr, progress, self.power)


Schedule = ConstantSchedule | AdaptiveKLSchedule | LinearSchedule | PolynomialSchedule
PROGRESS_SCHEDULES = (LinearSchedule, PolynomialSchedule)
"""Schedules that set the lr from the run's progress once per epoch (the others react to the KL)."""


def make_schedule(name: str | None, learning_rate: float, kl_threshold: float, min_lr: float,
                  max_lr: float, decay_power: float = 1.0, lr_multiplier: float = 1.5) -> Schedule:
    """The schedule named by ``lr_schedule``."""
    if name == "adaptive":
        return AdaptiveKLSchedule(kl_threshold, min_lr, max_lr, lr_multiplier)
    if name == "linear":
        return LinearSchedule(learning_rate, min_lr)
    if name == "polynom_decay":
        return PolynomialSchedule(learning_rate, min_lr, decay_power)
    return ConstantSchedule()
