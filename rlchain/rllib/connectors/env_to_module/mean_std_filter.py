"""RLlib's ``MeanStdFilter`` connector as a setting: returned by an ``env_to_module_connector`` function, it turns
on rlchain's observation normalizer (:func:`rlchain.rllib.obs_filter.filter_keys` reads it); it runs nothing."""

from __future__ import annotations

from typing import Any


class MeanStdFilter:
    """RLlib's running mean / std observation filter; its arguments are kept for the translation to read."""

    def __init__(self, *, multi_agent: bool = False, de_mean_to_zero: bool = True, de_std_to_one: bool = True,
                 clip_by_value: float | None = 10.0, update_stats: bool = True, **kwargs: Any) -> None:
        self.multi_agent = multi_agent
        self.de_mean_to_zero = de_mean_to_zero
        self.de_std_to_one = de_std_to_one
        self.clip_by_value = clip_by_value
        self.update_stats = update_stats

    def __repr__(self) -> str:
        return f"MeanStdFilter(clip_by_value={self.clip_by_value!r})"
