"""``ray.rllib.core.rl_module.torch.torch_rl_module``: ``TorchRLModule`` (an RLModule is a torch module here)."""

from rlchain.rllib.core.rl_module.rl_module import RLModule


class TorchRLModule(RLModule):
    """RLlib's torch module base: write ``setup`` and ``_forward*`` as RLlib's docs show."""


__all__ = ["TorchRLModule"]
