"""``ray.rllib.utils.metrics.metrics_logger``: ``MetricsLogger``. RLlib's Stats classes (``DEFAULT_STATS_CLS_LOOKUP``,
``reporting(custom_stats_cls_lookup=...)``) are not offered: each ends in one line naming the reduce kinds."""

from typing import Any

from rlchain.rllib.callbacks.callbacks import MetricsLogger
from rlchain.rllib.face_error import FaceImportError

STATS_INSTEAD = ("RLlib's Stats classes are not offered by rlchain's RLlib face: the face's MetricsLogger reduces "
                 "by log_value(key, value, reduce='ema' | 'mean' | 'min' | 'max' | 'sum' | 'lifetime_sum' | 'item' "
                 "| 'item_series', window=..., ema_coeff=...)")


def __getattr__(name: str) -> Any:
    if name in ("DEFAULT_STATS_CLS_LOOKUP", "Stats", "StatsBase"):
        raise FaceImportError(f"ray.rllib.utils.metrics.metrics_logger.{name}: {STATS_INSTEAD}", name=name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["MetricsLogger"]
