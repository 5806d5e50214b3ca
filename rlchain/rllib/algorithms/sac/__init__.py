"""``ray.rllib.algorithms.sac``: ``SACConfig`` and ``SAC`` trained by rlchain's SAC (twin critics, a learned
temperature towards ``target_entropy``) on Box or Discrete actions with RLlib 2.60's defaults (:mod:`.translate`
says what maps)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from rlchain.rllib.algorithm_class import exported
from rlchain.rllib.algorithms.sac.module import SACModuleView
from rlchain.rllib.algorithms.sac.translate import sac_config
from rlchain.rllib.config import AlgorithmConfig
from rlchain.rllib.core import DEFAULT_MODULE_ID
from rlchain.rllib.off_policy_algorithm import OffPolicyAlgorithm, target_updates
from rlchain.rllib.off_policy_results import sac_results


class SAC(OffPolicyAlgorithm):
    """RLlib's SAC on rlchain's SAC (Box or Discrete actions)."""

    algo_name = "SAC"
    action_spaces = (gym.spaces.Box, gym.spaces.Discrete)

    @classmethod
    def get_default_config(cls) -> SACConfig:
        return SACConfig()

    @staticmethod
    def translate(config: Any, env_name: str, obs_space: Any, continuous: bool, run: dict[str, Any]
                  ) -> dict[str, Any]:
        return sac_config(config, env_name, run, continuous)

    def get_module(self, module_id: str = DEFAULT_MODULE_ID) -> SACModuleView:
        """The trained policy as RLlib's RLModule: ``action_dist_inputs`` are pre-tanh means then log-stds (Box),
        or logits (Discrete)."""
        view = super().get_module(module_id)
        return SACModuleView(view.model, view.observation_space, view.action_space)

    def learner_results(self, stats: dict[str, Any], cfg: dict[str, Any]) -> dict[str, Any]:
        """RLlib's learner results (:func:`rlchain.rllib.off_policy_results.sac_results`)."""
        return sac_results(stats, cfg, target_updates(self))


SAC = exported(SAC)  # RLlib's SAC: config.algo_class is SAC, and Tune takes it (algorithm_class.py)


class SACConfig(AlgorithmConfig):
    """RLlib's SACConfig: actor_lr 3e-5, critic_lr 3e-4, alpha_lr 3e-4, tau 5e-3, initial_alpha 1.0, target_entropy
    'auto', train_batch_size 256, prioritized replay of 1e6, 1500 steps before learning, twin Q."""

    algo_name = "SAC"

    def __init__(self, algo_class: type | None = None) -> None:
        super().__init__(algo_class or SAC)


__all__ = ["SAC", "SACConfig"]
