"""``ray.rllib.algorithms``: the algorithm configs and classes under RLlib's names."""

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.algorithms.appo import APPO, APPOConfig
from rlchain.rllib.algorithms.dqn import DQN, DQNConfig
from rlchain.rllib.algorithms.impala import IMPALA, IMPALAConfig
from rlchain.rllib.algorithms.ppo import PPO, PPOConfig
from rlchain.rllib.algorithms.sac import SAC, SACConfig
from rlchain.rllib.config import AlgorithmConfig

__all__ = ["Algorithm", "AlgorithmConfig", "PPO", "PPOConfig", "APPO", "APPOConfig", "IMPALA", "IMPALAConfig",
           "DQN", "DQNConfig", "SAC", "SACConfig"]
