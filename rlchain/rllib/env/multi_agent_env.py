"""``ray.rllib.env.multi_agent_env``: ``MultiAgentEnv`` (subclassing works; training one is refused in one line)."""

from rlchain.rllib.multi_agent import MultiAgentEnv

__all__ = ["MultiAgentEnv"]
