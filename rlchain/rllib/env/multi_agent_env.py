"""``ray.rllib.env.multi_agent_env``: ``MultiAgentEnv`` and ``make_multi_agent`` (rlchain.rllib.multi_agent)."""

from rlchain.rllib.multi_agent import ENV_STATE, MultiAgentEnv, make_multi_agent

__all__ = ["ENV_STATE", "MultiAgentEnv", "make_multi_agent"]
