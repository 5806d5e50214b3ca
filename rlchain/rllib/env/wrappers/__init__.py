"""``ray.rllib.env.wrappers``: ``pettingzoo_env`` (PettingZoo games as RLlib ``MultiAgentEnv``s)."""
