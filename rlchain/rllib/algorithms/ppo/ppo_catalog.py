"""``ray.rllib.algorithms.ppo.ppo_catalog``: ``PPOCatalog``, the class RLlib's scripts pass as an ``RLModuleSpec``'s
``catalog_class`` (``pretraining_single_agent_training_multi_agent.py``). RLlib's catalog builds a PPO module's
encoder and heads from its model config; the face's PPO module builds the same layers from ``model_config`` itself
(:class:`rlchain.rllib.default_ppo_module.DefaultPPOTorchRLModule`), so the catalog is kept and has no effect."""

from __future__ import annotations

from typing import Any


class PPOCatalog:
    """RLlib's PPO catalog, by name: a module spec that names it builds the face's PPO module from its
    ``model_config``, as one without it does."""

    def __init__(self, observation_space: Any = None, action_space: Any = None, model_config_dict: Any = None,
                 **kwargs: Any) -> None:
        self.observation_space = observation_space
        self.action_space = action_space
        self.model_config_dict = model_config_dict


__all__ = ["PPOCatalog"]
