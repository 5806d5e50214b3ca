"""rlchain: PyTorch reinforcement learning that runs rl_games configs as written.

    import rlchain
    result = rlchain.Runner().load("rlchain/configs/ppo_cartpole.yaml").train()
    model = rlchain.PPO("MlpPolicy", "CartPole-v1").learn(50_000)   # Stable-Baselines3's shape
"""

import importlib

from rlchain.builtins import register_builtins  # noqa: E402
from rlchain.version import __version__  # noqa: E402

register_builtins()

from rlchain.runner import Runner  # noqa: E402

__all__ = ["Runner", "PPO", "SAC", "DQN", "__version__"]

_SB3 = ("PPO", "SAC", "DQN")  # Stable-Baselines3's names (rlchain.sb3), imported on first use


def __getattr__(name: str):
    if name in _SB3:
        return getattr(importlib.import_module("rlchain.sb3"), name)
    raise AttributeError(f"module 'rlchain' has no attribute '{name}'")
