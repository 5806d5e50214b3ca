"""Stable-Baselines3's API on rlchain: ``rlchain.PPO("MlpPolicy", "CartPole-v1").learn(50_000)``.

``PPO`` / ``SAC`` / ``DQN`` take SB3's constructor arguments (mapped to rlchain's config keys), train on
rlchain's own loop and config, and write the rl_games-style YAML they ran (``model.save_config``).
"""

from rlchain.sb3.algorithms import DQN, PPO, SAC
from rlchain.sb3.her import HerReplayBuffer

__all__ = ["PPO", "SAC", "DQN", "HerReplayBuffer"]
