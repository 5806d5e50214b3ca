"""``ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module``: ``DefaultPPOTorchRLModule``
(:mod:`rlchain.rllib.default_ppo_module`)."""

from rlchain.rllib.default_ppo_module import DefaultPPOTorchRLModule

__all__ = ["DefaultPPOTorchRLModule"]
