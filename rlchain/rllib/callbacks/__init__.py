"""``ray.rllib.callbacks``: :class:`RLlibCallback` (rlchain.rllib.callbacks.callbacks)."""

from rlchain.rllib.callbacks.callbacks import DefaultCallbacks, MetricsLogger, RLlibCallback

__all__ = ["DefaultCallbacks", "MetricsLogger", "RLlibCallback"]
