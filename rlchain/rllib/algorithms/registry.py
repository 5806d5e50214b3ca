"""The face's algorithms by RLlib's names: their config classes, and Ray Tune trainables under those names."""

from __future__ import annotations

from typing import Any

from rlchain.errors import did_you_mean
from rlchain.rllib.algorithm import ALGORITHMS as CLASSES
from rlchain.rllib.algorithm import Algorithm

ALGORITHMS = ("PPO", "APPO", "IMPALA", "DQN", "SAC")


def config_class(name: str) -> type:
    """The AlgorithmConfig class of algorithm ``name`` (PPO, APPO, IMPALA, DQN, SAC)."""
    if name not in CLASSES:
        raise ValueError(f"algorithm '{name}' is not offered by rlchain's RLlib face{did_you_mean(name, CLASSES)}")
    return type(CLASSES[name].get_default_config())


def _get_algorithm_class(name: str) -> Any:
    return CLASSES.get(name, Algorithm)
