"""``ray.rllib.algorithms.callbacks``: RLlib's older home of the callback base (``DefaultCallbacks``)."""

from rlchain.rllib.callbacks.callbacks import DefaultCallbacks, RLlibCallback

__all__ = ["DefaultCallbacks", "RLlibCallback"]
