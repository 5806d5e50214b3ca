"""``ray.rllib.algorithms.dqn.dqn``, the module RLlib defines ``DQN`` and ``DQNConfig`` in (scripts import either
path): the face's, from :mod:`rlchain.rllib.algorithms.dqn`."""

from rlchain.rllib.algorithms.dqn import DQN, DQNConfig

__all__ = ["DQN", "DQNConfig"]
