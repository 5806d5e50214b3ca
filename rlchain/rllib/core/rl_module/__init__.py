"""``ray.rllib.core.rl_module``: ``RLModule``, ``RLModuleSpec``, ``MultiRLModuleSpec`` and ``DefaultModelConfig``."""

from rlchain.rllib.core.rl_module.multi_rl_module import MultiRLModule, MultiRLModuleSpec
from rlchain.rllib.core.rl_module.rl_module import RLModule, RLModuleSpec
from rlchain.rllib.module import DefaultModelConfig

__all__ = ["DefaultModelConfig", "MultiRLModule", "MultiRLModuleSpec", "RLModule", "RLModuleSpec"]
