"""``ray.rllib.core.rl_module.torch.torch_rl_module``: ``TorchRLModule`` (see core.rl_module.rl_module)."""

from rlchain.rllib.core.rl_module.rl_module import RLModule


class TorchRLModule(RLModule):
    """RLlib's torch module base (written, not trained by the face)."""


__all__ = ["TorchRLModule"]
