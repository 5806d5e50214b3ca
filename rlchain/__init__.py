"""rlchain: PyTorch reinforcement learning that runs rl_games configs as written.

    import rlchain
    result = rlchain.Runner().load("rlchain/configs/ppo_cartpole.yaml").train()
"""

__version__ = "0.1.0"

from rlchain.builtins import register_builtins  # noqa: E402

register_builtins()

from rlchain.runner import Runner  # noqa: E402

__all__ = ["Runner", "__version__"]
