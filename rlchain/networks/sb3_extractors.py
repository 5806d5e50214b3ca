"""Stable-Baselines3's feature extractors and MLP extractor, as its users subclass and pass them.

SB3 users put their own network into a model with ``policy_kwargs=dict(features_extractor_class=MyExtractor,
features_extractor_kwargs=dict(features_dim=128))``; ``MyExtractor`` subclasses :class:`BaseFeaturesExtractor`
(this module's, or SB3's own when the script imports it from ``stable_baselines3.common.torch_layers``: both keep
the same contract). The contract, as SB3 documents it:

- ``__init__(observation_space, **features_extractor_kwargs)``; the base class takes ``features_dim``;
- ``forward(observations)`` -> ``(B, features_dim)``; ``observations`` are floats, uint8 images already divided
  by 255 and channel-first (the space given to ``__init__`` is the channel-first one), a Dict's keys per key.

:class:`MlpExtractor` is the ``mlp_extractor`` contract an ``ActorCriticPolicy._build_mlp_extractor`` override
fills: ``latent_dim_pi`` / ``latent_dim_vf``, ``forward_actor``, ``forward_critic`` and ``forward`` (both).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
from torch import nn


def is_image_space(space: gym.Space, normalized_image: bool = False) -> bool:
    """SB3's test of an image: a 3-dim Box, uint8 in [0, 255] (with ``normalized_image``: any 3-dim Box)."""
    if not isinstance(space, gym.spaces.Box) or len(space.shape) != 3:
        return False
    if normalized_image:
        return True
    return space.dtype == np.uint8 and bool(np.all(space.low == 0)) and bool(np.all(space.high == 255))


def is_channels_first(space: gym.spaces.Box) -> bool:
    """Whether an image space is (C, H, W): SB3's rule, the channel axis is the smallest one."""
    return int(np.argmin(space.shape)) == 0


def channels_first_space(space: gym.spaces.Box) -> gym.spaces.Box:
    """The (C, H, W) space of a channel-last (H, W, C) image space, as SB3's ``VecTransposeImage`` gives it."""
    order = (2, 0, 1)
    return gym.spaces.Box(np.transpose(space.low, order), np.transpose(space.high, order), dtype=space.dtype)


class BaseFeaturesExtractor(nn.Module):
    """The base of a features extractor: ``observation_space`` and the size of its output, ``features_dim``."""

    def __init__(self, observation_space: gym.Space, features_dim: int = 0) -> None:
        super().__init__()
        if features_dim <= 0:
            raise ValueError(f"{type(self).__name__}: features_dim must be > 0, got {features_dim}")
        self._observation_space = observation_space
        self._features_dim = int(features_dim)

    @property
    def features_dim(self) -> int:
        """The width of ``forward``'s output."""
        return self._features_dim

    def forward(self, observations: Any) -> torch.Tensor:  # pragma: no cover - interface
        raise NotImplementedError


class FlattenExtractor(BaseFeaturesExtractor):
    """Observations flattened into one vector (MlpPolicy's extractor)."""

    def __init__(self, observation_space: gym.Space) -> None:
        super().__init__(observation_space, int(gym.spaces.flatdim(observation_space)))
        self.flatten = nn.Flatten()

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        return self.flatten(observations)


class NatureCNN(BaseFeaturesExtractor):
    """The convolutions of DQN's Nature paper (32 8x8 / 4, 64 4x4 / 2, 64 3x3 / 1, ReLU), flattened, then one
    linear layer to ``features_dim`` with ReLU: CnnPolicy's extractor. Takes (C, H, W) images in [0, 1]."""

    def __init__(self, observation_space: gym.spaces.Box, features_dim: int = 512,
                 normalized_image: bool = False) -> None:
        if not isinstance(observation_space, gym.spaces.Box) or len(observation_space.shape) != 3:
            raise ValueError(f"NatureCNN needs image observations (a 3-dim Box), got {observation_space}")
        super().__init__(observation_space, features_dim)
        channels = int(observation_space.shape[0])
        self.cnn = nn.Sequential(nn.Conv2d(channels, 32, kernel_size=8, stride=4), nn.ReLU(),
                                 nn.Conv2d(32, 64, kernel_size=4, stride=2), nn.ReLU(),
                                 nn.Conv2d(64, 64, kernel_size=3, stride=1), nn.ReLU(), nn.Flatten())
        with torch.no_grad():
            flat = int(self.cnn(torch.zeros(1, *observation_space.shape)).shape[1])
        self.linear = nn.Sequential(nn.Linear(flat, features_dim), nn.ReLU())

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        return self.linear(self.cnn(observations))


class CombinedExtractor(BaseFeaturesExtractor):
    """Dict observations: a :class:`NatureCNN` of ``cnn_output_dim`` features per image key, each other key
    flattened, all concatenated in the space's key order (MultiInputPolicy's extractor)."""

    def __init__(self, observation_space: gym.spaces.Dict, cnn_output_dim: int = 256,
                 normalized_image: bool = False) -> None:
        super().__init__(observation_space, features_dim=1)
        extractors: dict[str, nn.Module] = {}
        total = 0
        for key, subspace in observation_space.spaces.items():
            if is_image_space(subspace, normalized_image):
                extractors[key] = NatureCNN(subspace, features_dim=cnn_output_dim, normalized_image=normalized_image)
                total += cnn_output_dim
            else:
                extractors[key] = nn.Flatten()
                total += int(gym.spaces.flatdim(subspace))
        self.extractors = nn.ModuleDict(extractors)
        self._features_dim = total

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        return torch.cat([extractor(observations[key]) for key, extractor in self.extractors.items()], dim=1)


def create_mlp(input_dim: int, output_dim: int, net_arch: list[int], activation_fn: type[nn.Module] = nn.ReLU,
               squash_output: bool = False) -> list[nn.Module]:
    """The layers of an MLP: (Linear, activation) per hidden size, then a Linear to ``output_dim`` when it is
    > 0 (and a Tanh with ``squash_output``)."""
    layers: list[nn.Module] = []
    size = input_dim
    for units in net_arch:
        layers += [nn.Linear(size, units), activation_fn()]
        size = units
    if output_dim > 0:
        layers.append(nn.Linear(size, output_dim))
    if squash_output:
        layers.append(nn.Tanh())
    return layers


def split_net_arch(net_arch: Any, second: str = "vf") -> tuple[list[int], list[int]]:
    """``(pi, vf)`` (or ``(pi, qf)``) hidden sizes of SB3's ``net_arch``: a list is both, a dict names each."""
    if net_arch is None:
        return [64, 64], [64, 64]
    if isinstance(net_arch, dict):
        return list(net_arch.get("pi", [])), list(net_arch.get(second, []))
    return list(net_arch), list(net_arch)


class MlpExtractor(nn.Module):
    """Features -> ``(latent_pi, latent_vf)``: an MLP for the actor (``policy_net``) and one for the critic
    (``value_net``), sized by ``net_arch`` (a list: the same sizes for both; ``dict(pi=[...], vf=[...])``)."""

    def __init__(self, feature_dim: int, net_arch: Any, activation_fn: type[nn.Module],
                 device: Any = "auto") -> None:
        super().__init__()
        pi, vf = split_net_arch(net_arch)
        self.policy_net = nn.Sequential(*create_mlp(feature_dim, 0, pi, activation_fn))
        self.value_net = nn.Sequential(*create_mlp(feature_dim, 0, vf, activation_fn))
        self.latent_dim_pi = pi[-1] if pi else feature_dim
        self.latent_dim_vf = vf[-1] if vf else feature_dim

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: torch.Tensor) -> torch.Tensor:
        return self.policy_net(features)

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return self.value_net(features)
