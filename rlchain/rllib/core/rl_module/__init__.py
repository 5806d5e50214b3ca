"""``ray.rllib.core.rl_module``: ``RLModuleSpec``, ``DefaultModelConfig`` and the ``RLModule`` names."""

from rlchain.rllib.core.rl_module.rl_module import RLModule, RLModuleSpec
from rlchain.rllib.module import DefaultModelConfig

__all__ = ["DefaultModelConfig", "RLModule", "RLModuleSpec"]
