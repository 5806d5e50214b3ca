"""``ray.rllib.algorithms.impala``: ``IMPALAConfig`` and ``IMPALA`` trained by rlchain's IMPALA (V-trace, runners that
sample while the learner trains) with RLlib 2.60's defaults (:mod:`rlchain.rllib.algorithms.impala.translate`
says what maps)."""

from __future__ import annotations

from typing import Any

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.algorithm_class import exported
from rlchain.rllib.algorithms.impala.translate import vtrace_config
from rlchain.rllib.config import AlgorithmConfig


class IMPALA(Algorithm):
    """RLlib's IMPALA on rlchain's IMPALA."""

    algo_name = "IMPALA"

    @classmethod
    def get_default_config(cls) -> IMPALAConfig:
        return IMPALAConfig()

    @staticmethod
    def translate(config: Any, env_name: str, obs_space: Any, continuous: bool, run: dict[str, Any]
                  ) -> dict[str, Any]:
        return vtrace_config(config, env_name, obs_space, continuous, run)


IMPALA = exported(IMPALA)  # RLlib's IMPALA: config.algo_class is IMPALA, and Tune takes it (algorithm_class.py)


class IMPALAConfig(AlgorithmConfig):
    """RLlib's IMPALAConfig: lr 5e-4, vf_loss_coeff 0.5, entropy_coeff 0.01, grad_clip 40, fragments of 50,
    train_batch_size 500, 2 env runners, V-trace (rho-bar 1), one pass per batch."""

    algo_name = "IMPALA"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or IMPALA)


__all__ = ["IMPALA", "IMPALAConfig"]
