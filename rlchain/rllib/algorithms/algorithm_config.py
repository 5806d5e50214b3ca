"""``ray.rllib.algorithms.algorithm_config``: :class:`AlgorithmConfig` (rlchain.rllib.config)."""

from rlchain.rllib.config import AlgorithmConfig

NotProvided = None

__all__ = ["AlgorithmConfig", "NotProvided"]
