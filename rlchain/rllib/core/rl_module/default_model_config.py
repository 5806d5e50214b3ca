"""``ray.rllib.core.rl_module.default_model_config``: ``DefaultModelConfig``."""

from rlchain.rllib.module import DefaultModelConfig

__all__ = ["DefaultModelConfig"]
