"""``ray.rllib.core.rl_module.torch``: ``TorchRLModule``."""

from rlchain.rllib.core.rl_module.torch.torch_rl_module import TorchRLModule

__all__ = ["TorchRLModule"]
