"""Stable-Baselines3's ``ActorCriticPolicy`` as its users subclass it, and the policy names CnnPolicy maps to.

SB3's custom_policy guide overrides ``_build_mlp_extractor`` to put its own ``mlp_extractor`` (an object with
``latent_dim_pi``, ``latent_dim_vf``, ``forward_actor``, ``forward_critic``) between the features extractor and
the heads, and passes the class as the policy: ``PPO(CustomActorCriticPolicy, "CartPole-v1")``. This class builds
the same parts under the same names, from the same constructor arguments:

- ``features_extractor`` (``pi_features_extractor`` / ``vf_features_extractor``: two with
  ``share_features_extractor=False``), ``features_dim``;
- ``mlp_extractor`` (:meth:`_build_mlp_extractor`, by default :class:`~rlchain.networks.sb3_extractors.MlpExtractor` of
  ``net_arch``), ``action_net`` (logits, or the Gaussian's mean), ``log_std`` (Box actions), ``value_net``;
- ``ortho_init``: orthogonal weights with SB3's gains (sqrt 2 for the extractors, 0.01 the action head, 1 the
  value head), zero biases.

rlchain trains it through :mod:`rlchain.networks.sb3_policy`, which reads these parts (a subclass of SB3's own
``ActorCriticPolicy`` has them too and trains the same way). No optimizer is made here: rlchain's PPO owns it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from torch import nn

from rlchain.networks.sb3_extractors import FlattenExtractor, MlpExtractor


def action_head_size(space: gym.Space) -> int:
    """Outputs of the action head: n (Discrete), sum(nvec) (MultiDiscrete), the action count (Box)."""
    if isinstance(space, gym.spaces.Discrete):
        return int(space.n)
    if isinstance(space, gym.spaces.MultiDiscrete):
        return int(np.sum(space.nvec))
    if isinstance(space, gym.spaces.Box):
        return int(np.prod(space.shape))
    raise ValueError(f"ActorCriticPolicy: action space {space} is not supported (Discrete, MultiDiscrete, Box)")


class ActorCriticPolicy(nn.Module):
    """See the module docstring. ``lr_schedule`` is taken for SB3's signature (rlchain's optimizer reads the
    model's ``learning_rate``)."""

    def __init__(self, observation_space: gym.Space, action_space: gym.Space, lr_schedule: Callable[[float], float],
                 net_arch: Any = None, activation_fn: type[nn.Module] = nn.Tanh, ortho_init: bool = True,
                 use_sde: bool = False, log_std_init: float = 0.0, full_std: bool = True, use_expln: bool = False,
                 squash_output: bool = False, features_extractor_class: type[nn.Module] = FlattenExtractor,
                 features_extractor_kwargs: dict[str, Any] | None = None, share_features_extractor: bool = True,
                 normalize_images: bool = True, optimizer_class: Any = None,
                 optimizer_kwargs: dict[str, Any] | None = None) -> None:
        super().__init__()
        if use_sde or squash_output:
            raise ValueError("ActorCriticPolicy: use_sde / squash_output (state-dependent exploration) are not in "
                             "rlchain")
        self.observation_space = observation_space
        self.action_space = action_space
        self.net_arch = dict(pi=[64, 64], vf=[64, 64]) if net_arch is None else net_arch
        self.activation_fn = activation_fn
        self.ortho_init = ortho_init
        self.log_std_init = float(log_std_init)
        self.features_extractor_class = features_extractor_class
        self.features_extractor_kwargs = dict(features_extractor_kwargs or {})
        self.share_features_extractor = share_features_extractor
        self.normalize_images = normalize_images
        self.features_extractor = self.make_features_extractor()
        self.features_dim = int(self.features_extractor.features_dim)
        if share_features_extractor:
            self.pi_features_extractor = self.vf_features_extractor = self.features_extractor
        else:
            self.pi_features_extractor = self.features_extractor
            self.vf_features_extractor = self.make_features_extractor()
        self._build(lr_schedule)

    def make_features_extractor(self) -> nn.Module:
        """A new features extractor of ``features_extractor_class`` for the observation space."""
        return self.features_extractor_class(self.observation_space, **self.features_extractor_kwargs)

    def _build_mlp_extractor(self) -> None:
        """``self.mlp_extractor``: override it to put your own network in (SB3's contract)."""
        self.mlp_extractor = MlpExtractor(self.features_dim, self.net_arch, self.activation_fn)

    def _build(self, lr_schedule: Callable[[float], float]) -> None:
        self._build_mlp_extractor()
        latent_pi = int(self.mlp_extractor.latent_dim_pi)
        self.action_net = nn.Linear(latent_pi, action_head_size(self.action_space))
        if isinstance(self.action_space, gym.spaces.Box):
            self.log_std = nn.Parameter(torch.full((action_head_size(self.action_space),), self.log_std_init))
        self.value_net = nn.Linear(int(self.mlp_extractor.latent_dim_vf), 1)
        if self.ortho_init:
            gains = {self.features_extractor: math.sqrt(2), self.mlp_extractor: math.sqrt(2),
                     self.action_net: 0.01, self.value_net: 1.0}
            if not self.share_features_extractor:
                gains[self.vf_features_extractor] = math.sqrt(2)
            for module, gain in gains.items():
                module.apply(lambda m, g=gain: orthogonal_init(m, g))

    def extract_features(self, obs: Any) -> Any:
        """Features of (already preprocessed) ``obs``: one tensor, or ``(pi, vf)`` with separate extractors."""
        if self.share_features_extractor:
            return self.features_extractor(obs)
        return self.pi_features_extractor(obs), self.vf_features_extractor(obs)


def orthogonal_init(module: nn.Module, gain: float) -> None:
    """Orthogonal weights of ``gain`` and zero biases for a Linear or a convolution."""
    if isinstance(module, (nn.Linear, nn.Conv2d, nn.Conv1d)):
        nn.init.orthogonal_(module.weight, gain=gain)
        if module.bias is not None:
            module.bias.data.fill_(0.0)


MultiInputActorCriticPolicy = ActorCriticPolicy
ActorCriticCnnPolicy = ActorCriticPolicy
