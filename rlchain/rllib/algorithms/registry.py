"""The face's algorithms by RLlib's names: their config classes, and Ray Tune trainables under those names."""

from __future__ import annotations

from typing import Any

ALGORITHMS = ("PPO", "APPO", "IMPALA", "DQN", "SAC")


def config_class(name: str) -> type:
    """The AlgorithmConfig class of algorithm ``name`` (PPO, APPO, IMPALA, DQN, SAC)."""
    from rlchain.rllib.algorithms import appo, dqn, impala, ppo, sac
    classes = {"PPO": ppo.PPOConfig, "APPO": appo.APPOConfig, "IMPALA": impala.IMPALAConfig, "DQN": dqn.DQNConfig,
               "SAC": sac.SACConfig}
    if name not in classes:
        from rlchain.errors import did_you_mean
        raise ValueError(f"algorithm '{name}' is not offered by rlchain's RLlib face{did_you_mean(name, classes)}")
    return classes[name]


def _get_algorithm_class(name: str) -> Any:
    from rlchain.rllib.algorithm import Algorithm
    return Algorithm
