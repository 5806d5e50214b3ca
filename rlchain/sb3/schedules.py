"""SB3's schedules: ``learning_rate=fn`` (and PPO's ``clip_range=fn``), ``fn(progress_remaining)`` going from 1 at
the start of ``learn`` to 0 at its end.

The config holds the value at progress 1 (a YAML holds numbers, and a saved model its arguments as data);
:class:`ScheduleCallback` sets the live value after every epoch from the run's frames, as SB3 sets it before each
update from ``1 - num_timesteps / total_timesteps``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rlchain.training.events import Callback

SCHEDULED = {"ppo": {"learning_rate": ("learning_rate",), "clip_range": ("e_clip",)},
             "sac": {"learning_rate": ("actor_lr", "critic_lr", "alpha_lr")},
             "dqn": {"learning_rate": ("learning_rate",)}}
"""Per algorithm: the SB3 arguments that may be schedules -> the rlchain parameters they set."""


def split_schedules(algo: str, given: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Callable[[float], float]]]:
    """``given`` with each schedule replaced by its value at progress 1, and the schedules by argument name.
    ValueError (``name: ...``) when a schedule does not return a number."""
    values, schedules = dict(given), {}
    for name in SCHEDULED[algo]:
        fn = given.get(name)
        if callable(fn):
            values[name] = schedule_value(name, fn, 1.0)
            schedules[name] = fn
    return values, schedules


def schedule_value(name: str, fn: Callable[[float], float], progress_remaining: float) -> float:
    """``fn(progress_remaining)`` as a float, else a ValueError naming the argument."""
    value = fn(progress_remaining)
    if isinstance(value, bool) or not isinstance(value, (int, float)) and not hasattr(value, "__float__"):
        raise ValueError(f"{name}: a schedule must return a number, {fn!r}({progress_remaining}) gave {value!r}")
    return float(value)


class ScheduleCallback(Callback):
    """Sets the scheduled parameters after every epoch: ``fn(1 - (frames - start) / total)``."""

    def __init__(self, algo: str, schedules: dict[str, Callable[[float], float]], start: int, total: int) -> None:
        self.targets = {name: (fn, SCHEDULED[algo][name]) for name, fn in schedules.items()}
        self.start, self.total = start, max(1, total)

    def on_epoch_end(self, ctx: Any, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        progress = max(0.0, 1.0 - (ctx.state.frames - self.start) / self.total)
        changes = {}
        for name, (fn, keys) in self.targets.items():
            value = schedule_value(name, fn, progress)
            changes.update({key: value for key in keys})
        ctx.set_params(**changes)
