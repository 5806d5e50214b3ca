"""SAC (algo ``sac``): the off-policy loop of :mod:`~rlchain.algos.off_policy.off_policy` with the
:class:`~rlchain.algos.off_policy.sac_agent.SACAgent` (twin critics, a learned temperature) on a Box action space
(a tanh-squashed Gaussian actor) or a Discrete one (a categorical actor, critics with one Q-value per action:
:mod:`~rlchain.algos.off_policy.sac_discrete`), and the ``soft_actor_critic`` model factory choosing between them."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import torch.nn as nn

from rlchain.algos.off_policy.off_policy import OffPolicyAlgorithm
from rlchain.algos.off_policy.sac_agent import SACAgent, SoftActorCritic
from rlchain.algos.off_policy.sac_discrete import DiscreteSoftActorCritic
from rlchain.config.off_policy import SACConfig


class SAC(OffPolicyAlgorithm):
    """Algo ``sac``."""

    config_class = SACConfig
    metric_tags = {"actor_loss": "losses/actor_loss", "critic_loss": "losses/critic_loss",
                   "alpha_loss": "losses/alpha_loss", "entropy": "losses/entropy", "q": "info/q",
                   "alpha": "info/alpha", **OffPolicyAlgorithm.SHARED_TAGS}
    console_fields = tuple((name, name + " {:.3g}") for name in
                           ("actor_loss", "critic_loss", "alpha_loss", "entropy", "q", "alpha"))
    tunable = ("actor_lr", "critic_lr", "alpha_lr", "gamma", "critic_tau", "batch_size", "num_updates_per_step",
               "policy_frequency")

    def make_agent(self) -> SACAgent:
        return SACAgent(self.model, self.cfg)

    def extra_stats(self) -> dict[str, float]:
        stats = {"alpha": float(self.model.alpha.detach())}
        if self.agent.rllib_stats:  # RLlib's results report it (rlchain's own logs do not)
            stats["target_entropy"] = self.agent.target_entropy
        return stats


def soft_actor_critic_model(network: nn.Module, action_space: gym.Space, obs_shape: tuple, value_size: int,
                            config: Any, model_name: str) -> SoftActorCritic:
    """MODELS factory ``soft_actor_critic``: the squashed-Gaussian model for Box actions, the categorical one for
    Discrete actions."""
    normalize, alpha = getattr(config, "normalize_input", False), getattr(config, "init_alpha", 1.0)
    exclude = tuple(getattr(config, "obs_normalizer_exclude", ()))
    if isinstance(action_space, gym.spaces.Discrete):
        return DiscreteSoftActorCritic(network, action_space, obs_shape, normalize, alpha,
                                       obs_normalizer_exclude=exclude)
    if not isinstance(action_space, gym.spaces.Box):
        raise ValueError(f"params.model.name: soft_actor_critic needs Box or Discrete actions, the env has "
                         f"{action_space}")
    return SoftActorCritic(network, action_space, obs_shape, normalize, alpha, getattr(config, "clip_actions", True),
                           getattr(config, "log_std_bounds", None), exclude)
