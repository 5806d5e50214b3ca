"""``ray.rllib.env``: ``EnvContext`` and ``MultiAgentEnv``."""

from rlchain.rllib.envs import EnvContext
from rlchain.rllib.multi_agent import MultiAgentEnv

__all__ = ["EnvContext", "MultiAgentEnv"]
