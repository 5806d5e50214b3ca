"""``ray.rllib.algorithms.impala``: ``IMPALAConfig`` (its keys are accepted; building it is a one-line error naming
rlchain's IMPALA YAML: the face trains PPO)."""

from __future__ import annotations

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.config import AlgorithmConfig


class IMPALA(Algorithm):
    """RLlib's IMPALA: not trained by the face (see the module docstring)."""

    algo_name = "IMPALA"

    @classmethod
    def get_default_config(cls) -> IMPALAConfig:
        return IMPALAConfig()


class IMPALAConfig(AlgorithmConfig):
    algo_name = "IMPALA"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or IMPALA)


__all__ = ["IMPALA", "IMPALAConfig"]
