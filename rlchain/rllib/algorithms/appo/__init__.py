"""``ray.rllib.algorithms.appo``: ``APPOConfig`` and ``APPO`` trained by rlchain's APPO (V-trace, runners that
sample while the learner trains) with RLlib 2.60's defaults (:mod:`rlchain.rllib.algorithms.impala.translate`
says what maps)."""

from __future__ import annotations

from typing import Any

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.algorithm_class import exported
from rlchain.rllib.algorithms.impala.translate import vtrace_config
from rlchain.rllib.config import AlgorithmConfig


class APPO(Algorithm):
    """RLlib's APPO on rlchain's APPO."""

    algo_name = "APPO"

    @classmethod
    def get_default_config(cls) -> APPOConfig:
        return APPOConfig()

    @staticmethod
    def translate(config: Any, env_name: str, obs_space: Any, continuous: bool, run: dict[str, Any]
                  ) -> dict[str, Any]:
        return vtrace_config(config, env_name, obs_space, continuous, run)


APPO = exported(APPO)  # RLlib's APPO: config.algo_class is APPO, and Tune takes it (algorithm_class.py)


class APPOConfig(AlgorithmConfig):
    """RLlib's APPOConfig: lr 5e-4, clip_param 0.4, vf_loss_coeff 0.5, entropy_coeff 0.01, grad_clip 40, fragments
    of 50, train_batch_size 500, 2 env runners, V-trace (rho-bar 1), the circular buffer's 2 passes per batch."""

    algo_name = "APPO"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or APPO)


__all__ = ["APPO", "APPOConfig"]
