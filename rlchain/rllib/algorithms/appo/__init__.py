"""``ray.rllib.algorithms.appo``: ``APPOConfig`` (its keys are accepted; building it is a one-line error naming
rlchain's APPO YAML: the face trains PPO)."""

from __future__ import annotations

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.config import AlgorithmConfig


class APPO(Algorithm):
    """RLlib's APPO: not trained by the face (see the module docstring)."""

    algo_name = "APPO"

    @classmethod
    def get_default_config(cls) -> APPOConfig:
        return APPOConfig()


class APPOConfig(AlgorithmConfig):
    algo_name = "APPO"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or APPO)


__all__ = ["APPO", "APPOConfig"]
