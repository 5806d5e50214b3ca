"""``ray.rllib.algorithms.ppo``: ``PPOConfig`` and ``PPO`` trained by rlchain's PPO with RLlib's loss (its KL
penalty with the adaptive coefficient, the clipped value loss) and RLlib's defaults."""

from __future__ import annotations

from typing import Any

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.algorithm_class import exported
from rlchain.rllib.config import AlgorithmConfig
from rlchain.rllib.results import learner_results


class PPO(Algorithm):
    """RLlib's PPO on rlchain's loop."""

    algo_name = "PPO"

    @classmethod
    def get_default_config(cls) -> PPOConfig:
        return PPOConfig()

    @staticmethod
    def learner_results(stats: dict[str, Any], cfg: dict[str, Any]) -> dict[str, Any]:
        """RLlib's PPO learner results (:func:`rlchain.rllib.results.learner_results`) and
        ``module_train_batch_size_mean``, the rows of a minibatch update (RLlib's mean over its updates: each of its
        cyclic minibatches has ``minibatch_size`` rows)."""
        return {**learner_results(stats), "module_train_batch_size_mean": float(cfg.get("minibatch_size", "nan"))}


PPO = exported(PPO)  # RLlib's PPO: config.algo_class is PPO, and Tune takes it (algorithm_class.py)


class PPOConfig(AlgorithmConfig):
    """RLlib's PPOConfig: lr 5e-5, train_batch_size 4000, minibatch_size 128, num_epochs 30, lambda_ 1.0,
    clip_param 0.3, vf_clip_param 10.0, use_kl_loss with kl_coeff 0.2 and kl_target 0.01, 2 env runners."""

    algo_name = "PPO"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or PPO)


__all__ = ["PPO", "PPOConfig"]
