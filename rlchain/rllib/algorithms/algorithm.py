"""``ray.rllib.algorithms.algorithm``: :class:`Algorithm` (rlchain.rllib.algorithm)."""

from rlchain.rllib.algorithm import Algorithm

__all__ = ["Algorithm"]
