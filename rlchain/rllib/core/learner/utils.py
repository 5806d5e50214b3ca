"""``ray.rllib.core.learner.utils``: RLlib's target-network helpers, which RLlib's example RLModules (their
``TargetNetworkAPI``) import. The face's PPO does not ask a module for target networks; these only build and
update them as RLlib's do."""

from __future__ import annotations

import copy

import torch


def make_target_network(main_net: torch.nn.Module) -> torch.nn.Module:
    """A deep copy of ``main_net`` (same weights) that is not trained."""
    if not isinstance(main_net, torch.nn.Module):
        raise ValueError(f"make_target_network: expected a torch.nn.Module, got {type(main_net).__name__}")
    return copy.deepcopy(main_net).requires_grad_(False)


@torch.no_grad()
def update_target_network(*, main_module: torch.nn.Module, target_module: torch.nn.Module, tau: float) -> None:
    """Polyak update in place: ``target = tau * main + (1 - tau) * target``, parameter by parameter."""
    for main, target in zip(main_module.parameters(), target_module.parameters(), strict=True):
        target.mul_(1.0 - tau).add_(main, alpha=tau)


__all__ = ["make_target_network", "update_target_network"]
