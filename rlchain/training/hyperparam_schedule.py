"""Replays ``params.config.hyperparam_schedule`` (e.g. the schedule a PBT winner followed) through the
run's live ``set_params`` (the callback context's, :class:`~rlchain.training.live_params.LiveParams`').

Entry ``E: {name: value}`` is in force from the epoch after ``E`` completed epochs (``0``: from the
start), the point at which population-based training changed the winner's values.
"""

from __future__ import annotations

from rlchain.config.errors import ConfigError
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback


def check_names(schedule: dict[int, dict[str, float]], tunable: tuple[str, ...], algo: str,
                source: str) -> None:
    """A one-line ConfigError for a scheduled name the algorithm cannot change live."""
    for epoch, values in schedule.items():
        for name in values:
            if name not in tunable:
                raise ConfigError(source, f"params.config.hyperparam_schedule.{epoch}.{name}",
                                  f"'{name}' cannot change live for {algo} (tunable: {', '.join(tunable)})")


def values_at(schedule: dict[int, dict[str, float]], epochs_done: int) -> dict[str, float]:
    """The scheduled values in force after ``epochs_done`` epochs (later entries win)."""
    out: dict[str, float] = {}
    for epoch in sorted(schedule):
        if epoch <= epochs_done:
            out.update(schedule[epoch])
    return out


class HyperparamSchedule(Callback):
    """Sets the scheduled values at the start (a resume gets those in force at its epoch) and after
    each epoch that begins a new entry."""

    def __init__(self, schedule: dict[int, dict[str, float]]) -> None:
        self.schedule = {int(epoch): dict(values) for epoch, values in schedule.items()}

    def on_train_start(self, ctx: CallbackContext) -> None:
        values = values_at(self.schedule, ctx.state.epoch)
        if values:
            ctx.set_params(**values)

    def on_epoch_end(self, ctx: CallbackContext, stats: dict, episodes: dict | None) -> None:
        values = self.schedule.get(ctx.state.epoch)
        if values:
            ctx.set_params(**values)
