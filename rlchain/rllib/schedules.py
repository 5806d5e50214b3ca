"""RLlib's schedules as a setting's value: ``lr=[[0, 1e-5], [1000000, 1e-4]]``, ``entropy_coeff=[[0, 0.05], ...]``.

A schedule is a list of ``[timestep, value]`` pairs, the first at timestep 0, the timesteps increasing; the value
at a timestep (env steps sampled over the run) is the linear interpolation between the pairs around it, and the
last value after the last pair (RLlib's ``Scheduler``: a ``PiecewiseSchedule`` whose outside value is the last).
RLlib's Learner sets the next value after each update, at the env steps sampled so far, so ``train()`` number k
updates with the value at the env steps the k - 1 calls before it sampled (the first with the value at 0). The
face does the same: rlchain trains with the value at 0 and, before each ``train()``, the algorithm sets the value
at the env steps sampled so far as a live parameter (rlchain's ``set_params``, applied at the next epoch's start).
"""

from __future__ import annotations

import bisect
from typing import Any

from rlchain.config.errors import ConfigError

SCHEDULED = {"PPO": {"lr": "learning_rate", "entropy_coeff": "entropy_coef"},
             "APPO": {"lr": "learning_rate", "entropy_coeff": "entropy_coef"},
             "IMPALA": {"lr": "learning_rate", "entropy_coeff": "entropy_coef"},
             "DQN": {"lr": "learning_rate"}}
"""The RLlib settings the face schedules, per algorithm -> the rlchain parameter each one sets."""


def pairs(config: Any, key: str, value: Any) -> list[tuple[float, float]]:
    """``value`` as checked ``(timestep, value)`` pairs (one line naming the key when it is not a schedule)."""
    where = type(config).__name__
    try:
        out = [(float(t), float(v)) for t, v in value]
    except (TypeError, ValueError):
        raise ConfigError(where, key, f"a schedule is a list of [timestep, value] pairs, got {value!r}") from None
    if not out or out[0][0] != 0:
        raise ConfigError(where, key, f"a schedule's first pair is at timestep 0 (RLlib's rule), got {value!r}")
    if any(b[0] <= a[0] for a, b in zip(out, out[1:])):
        raise ConfigError(where, key, f"a schedule's timesteps increase, got {value!r}")
    return out


def value_at(schedule: list[tuple[float, float]], timestep: float) -> float:
    """The schedule's value at ``timestep``: linear between the pairs around it, the last value after the last."""
    times = [t for t, _ in schedule]
    i = bisect.bisect_right(times, timestep)
    if i >= len(schedule):
        return schedule[-1][1]
    (t0, v0), (t1, v1) = schedule[i - 1], schedule[i]
    return v0 + (timestep - t0) / (t1 - t0) * (v1 - v0)


class Schedules:
    """The scheduled settings of one config: the constant config rlchain starts from, the values to set."""

    def __init__(self, config: Any) -> None:
        names = SCHEDULED.get(config.algo_name, {})
        settings = config._settings
        self.by_param = {param: pairs(config, key, settings[key]) for key, param in names.items()
                         if isinstance(settings.get(key), (list, tuple))}
        self._keys = {param: key for key, param in names.items()}

    def __bool__(self) -> bool:
        return bool(self.by_param)

    def starting_config(self, config: Any) -> Any:
        """A copy of ``config`` with each schedule's value at timestep 0 (what rlchain's config starts from)."""
        out = config.copy(copy_frozen=False)
        for param, schedule in self.by_param.items():
            out._settings[self._keys[param]] = schedule[0][1]
        return out

    def at(self, timestep: float) -> dict[str, float]:
        """rlchain's live parameters at ``timestep`` env steps."""
        return {param: value_at(schedule, timestep) for param, schedule in self.by_param.items()}
