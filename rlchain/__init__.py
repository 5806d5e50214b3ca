"""rlchain: PyTorch reinforcement learning that runs rl_games configs as written.

    import rlchain
    result = rlchain.Runner().load("rlchain/configs/ppo_cartpole.yaml").train()
"""

from rlchain.builtins import register_builtins  # noqa: E402
from rlchain.version import __version__  # noqa: E402

register_builtins()

from rlchain.runner import Runner  # noqa: E402

__all__ = ["Runner", "__version__"]
