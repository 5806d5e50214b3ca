"""``ray.rllib.algorithms.dqn``: ``DQNConfig`` (its keys are accepted; building it is a one-line error naming
rlchain's DQN YAML: the face trains PPO)."""

from __future__ import annotations

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.config import AlgorithmConfig


class DQN(Algorithm):
    """RLlib's DQN: not trained by the face (see the module docstring)."""

    algo_name = "DQN"

    @classmethod
    def get_default_config(cls) -> DQNConfig:
        return DQNConfig()


class DQNConfig(AlgorithmConfig):
    algo_name = "DQN"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or DQN)


__all__ = ["DQN", "DQNConfig"]
