"""``ray.rllib.utils.metrics.metrics_logger``: ``MetricsLogger``."""

from rlchain.rllib.callbacks.callbacks import MetricsLogger

__all__ = ["MetricsLogger"]
