"""``ray.rllib.algorithms.dqn``: ``DQNConfig`` and ``DQN`` trained by rlchain's DQN (double / dueling Q, n-step,
prioritized replay, target updates) with RLlib's defaults and replay ratio."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from rlchain.rllib import translate
from rlchain.rllib.algorithm_class import exported
from rlchain.rllib.config import AlgorithmConfig
from rlchain.rllib.off_policy_algorithm import OffPolicyAlgorithm, target_updates
from rlchain.rllib.off_policy_results import dqn_results


class DQN(OffPolicyAlgorithm):
    """RLlib's DQN on rlchain's DQN."""

    algo_name = "DQN"
    action_spaces = (gym.spaces.Discrete,)

    @classmethod
    def get_default_config(cls) -> DQNConfig:
        return DQNConfig()

    @staticmethod
    def translate(config: Any, env_name: str, obs_space: Any, continuous: bool, run: dict[str, Any]
                  ) -> dict[str, Any]:
        return translate.dqn_config(config, env_name, run)

    def learner_results(self, stats: dict[str, Any], cfg: dict[str, Any]) -> dict[str, Any]:
        """RLlib's learner results (:func:`rlchain.rllib.off_policy_results.dqn_results`)."""
        return dqn_results(stats, cfg, target_updates(self))


DQN = exported(DQN)  # RLlib's DQN: config.algo_class is DQN, and Tune takes it (algorithm_class.py)


class DQNConfig(AlgorithmConfig):
    """RLlib's DQNConfig: lr 5e-4, train_batch_size 32, double_q, dueling, n_step 1, prioritized replay of 50,000,
    target_network_update_freq 500, epsilon [(0, 1.0), (10000, 0.05)], 1000 env steps per iteration."""

    algo_name = "DQN"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or DQN)


__all__ = ["DQN", "DQNConfig"]
