"""``ray.rllib.algorithms.ppo.ppo``, the module RLlib defines ``PPO`` and ``PPOConfig`` in (scripts import either
path): the face's, from :mod:`rlchain.rllib.algorithms.ppo`."""

from rlchain.rllib.algorithms.ppo import PPO, PPOConfig

__all__ = ["PPO", "PPOConfig"]
