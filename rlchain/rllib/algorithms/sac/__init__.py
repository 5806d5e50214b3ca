"""``ray.rllib.algorithms.sac``: ``SACConfig`` (its keys are accepted; building it is a one-line error naming
rlchain's SAC YAML: the face trains PPO)."""

from __future__ import annotations

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.config import AlgorithmConfig


class SAC(Algorithm):
    """RLlib's SAC: not trained by the face (see the module docstring)."""

    algo_name = "SAC"

    @classmethod
    def get_default_config(cls) -> SACConfig:
        return SACConfig()


class SACConfig(AlgorithmConfig):
    algo_name = "SAC"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or SAC)


__all__ = ["SAC", "SACConfig"]
