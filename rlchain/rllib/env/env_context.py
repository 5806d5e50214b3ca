"""``ray.rllib.env.env_context``: ``EnvContext``."""

from rlchain.rllib.envs import EnvContext

__all__ = ["EnvContext"]
