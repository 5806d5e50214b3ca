"""rlchain: PyTorch reinforcement learning that runs rl_games configs as written.

    import rlchain
    result = rlchain.Runner().load("rlchain/configs/ppo_cartpole.yaml").train()
    model = rlchain.PPO("MlpPolicy", "CartPole-v1").learn(50_000)   # Stable-Baselines3's shape

``import rlchain`` is light: torch, the built-in algorithms and networks load on first use (a registry lookup,
``rlchain.Runner``, ``rlchain.PPO``), so the ``rlchain`` command answers ``--help`` and ``list`` at once.
"""

import importlib
from typing import TYPE_CHECKING

from rlchain.registry import load_builtins_with
from rlchain.version import __version__

if TYPE_CHECKING:  # what __getattr__ hands out, for type checkers and the API docs
    from rlchain.runner import Runner
    from rlchain.sb3 import DQN, PPO, SAC, HerReplayBuffer

__all__ = ["Runner", "PPO", "SAC", "DQN", "HerReplayBuffer", "__version__"]

_LAZY = {"Runner": "rlchain.runner", "PPO": "rlchain.sb3", "SAC": "rlchain.sb3", "DQN": "rlchain.sb3",
         "HerReplayBuffer": "rlchain.sb3"}
"""Top-level names and the module each comes from, imported on first use."""


def _register_builtins() -> None:
    importlib.import_module("rlchain.builtins").register_builtins()


load_builtins_with(_register_builtins)


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'rlchain' has no attribute '{name}'")
