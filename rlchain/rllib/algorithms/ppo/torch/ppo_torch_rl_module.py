"""``ray.rllib.algorithms.ppo.torch.ppo_torch_rl_module``: RLlib's older name ``PPOTorchRLModule``."""

from rlchain.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule

PPOTorchRLModule = DefaultPPOTorchRLModule

__all__ = ["PPOTorchRLModule"]
