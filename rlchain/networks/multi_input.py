"""The ``multi_input`` network: an encoder per observation key, fused, then the actor-critic trunk and heads.

Dict observations arrive per key (an :class:`~rlchain.envs.obs_dict.ObsDict`, images as floats in [0, 1],
vectors normalized by the model, Discrete values as int64). Each key goes through its own encoder
(``network.inputs.<key>``: a CNN or IMPALA stages for an image, an MLP or nothing for a vector, an embedding
for a Discrete / MultiDiscrete key; ``none`` leaves the key out, so an actor and a critic can read different
keys), the features are concatenated in the space's key order and the result feeds
:class:`~rlchain.networks.actor_critic.ActorCriticNetwork`'s trunk (``actor_cnn`` is the encoder, then
``actor_mlp``, optional ``rnn``) and heads.
For the off-policy models (SAC, DQN) the same encoders feed their own networks (networks/sac_network.py).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from rlchain.config.multi_input import InputConfig, MultiInputNetworkConfig
from rlchain.config.network import CnnConfig, MlpConfig, ResnetCnnConfig
from rlchain.envs.obs_dict import discrete_layout, is_dict_space, is_discrete
from rlchain.networks.actor_critic import ActorCriticNetwork, is_continuous, logits_sizes
from rlchain.networks.cnn import ConvEncoder
from rlchain.networks.impala import ImpalaEncoder
from rlchain.networks.mlp import MLP
from rlchain.networks.sac_network import OFF_POLICY_MODELS, multi_input_off_policy


def random_shift(images: torch.Tensor, pad: int) -> torch.Tensor:
    """DrQ's augmentation: each image (B, C, H, W) padded by ``pad`` pixels (edges replicated) and cropped
    back to (H, W) at its own random integer offset in [0, 2 pad]."""
    b, _, h, w = images.shape
    padded = F.pad(images, (pad, pad, pad, pad), mode="replicate")
    dy = torch.randint(0, 2 * pad + 1, (b, 1, 1), device=images.device)
    dx = torch.randint(0, 2 * pad + 1, (b, 1, 1), device=images.device)
    rows = (torch.arange(h, device=images.device).view(1, h, 1) + dy).expand(b, h, w)
    cols = (torch.arange(w, device=images.device).view(1, 1, w) + dx).expand(b, h, w)
    flat = (rows * (w + 2 * pad) + cols).view(b, 1, h * w).expand(-1, images.shape[1], -1)
    return padded.flatten(2).gather(2, flat).view_as(images)


class ImageEncoder(nn.Module):
    """(B, C, H, W) floats -> (B, out_size): convolutions (cnn or impala), then optionally a linear layer
    with activation to ``units[-1]`` features; ``random_shift`` augments in training passes only."""

    def __init__(self, cfg: InputConfig, shape: tuple[int, ...], kind: str) -> None:
        super().__init__()
        permute = channels_last(shape) if cfg.permute_input is None else cfg.permute_input
        if kind == "cnn":
            self.convs: nn.Module = ConvEncoder(CnnConfig(type="conv2d", permute_input=permute,
                                                          activation=cfg.activation, convs=cfg.convs), shape)
        else:
            self.convs = ImpalaEncoder(ResnetCnnConfig(permute_input=permute,
                                                       conv_depths=cfg.conv_depths, activation=cfg.activation),
                                       shape)
        self.head = MLP(self.convs.out_size, MlpConfig(units=cfg.units[-1:], activation=cfg.activation))
        self.out_size = self.head.out_size
        self.shift = cfg.random_shift
        self.permute = permute

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if self.shift and self.training:
            x = random_shift(x.permute(0, 3, 1, 2), self.shift).permute(0, 2, 3, 1) if self.permute \
                else random_shift(x, self.shift)
        return self.head(self.convs(x))


class FlatEncoder(nn.Module):
    """(B, *shape) -> (B, out_size): the values flattened, through an MLP of ``units`` (none for flatten). A
    Discrete / MultiDiscrete key is one-hot first (gymnasium's flattening of it, SB3's preprocessing)."""

    def __init__(self, cfg: InputConfig, space: gym.Space, kind: str) -> None:
        super().__init__()
        self.one_hot = DiscreteIndex(space) if is_discrete(space) else None
        size = self.one_hot.total if self.one_hot is not None else int(np.prod(space.shape))
        self.mlp = MLP(size, MlpConfig(units=list(cfg.units) if kind == "mlp" else [], activation=cfg.activation))
        self.out_size = self.mlp.out_size

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if self.one_hot is not None:  # the sum of one-hots of the components' rows in the shared table
            hot = torch.zeros(x.shape[0], self.one_hot.total, device=x.device)
            return self.mlp(hot.scatter_(1, self.one_hot(x), 1.0))
        return self.mlp(x.reshape(x.shape[0], -1))  # a scalar key (B,) too


class DiscreteIndex(nn.Module):
    """(B,) or (B, *nvec.shape) integer values -> (B, components) rows of one table shared by the components:
    each component's value minus its ``start``, offset by the sizes of the components before it."""

    def __init__(self, space: gym.spaces.Discrete | gym.spaces.MultiDiscrete) -> None:
        super().__init__()
        sizes, starts, offsets = discrete_layout(space)
        self.register_buffer("shift", torch.as_tensor(offsets - starts), persistent=False)
        self.total, self.components = int(sizes.sum()), int(sizes.size)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x.reshape(x.shape[0], self.components).long() + self.shift


class EmbeddingEncoder(nn.Module):
    """(B,) or (B, *nvec.shape) integer values -> (B, components * dim): a learned ``dim``-vector per value of
    each component (one table, the components' rows apart), concatenated. The values are the env's own
    (``start`` included), stored as int64 and never normalized."""

    def __init__(self, cfg: InputConfig, space: gym.spaces.Discrete | gym.spaces.MultiDiscrete) -> None:
        super().__init__()
        self.index = DiscreteIndex(space)
        self.table = nn.Embedding(self.index.total, cfg.dim)
        self.out_size = self.index.components * cfg.dim

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.table(self.index(x)).flatten(1)


def channels_last(shape: tuple[int, ...]) -> bool:
    """Whether an image of ``shape`` is (H, W, C): unless its first dim is its smallest (SB3's rule)."""
    return int(np.argmin(shape)) != 0


def encoder_kind(cfg: InputConfig, space: gym.Space) -> str:
    """The encoder ``cfg.encoder`` names, ``auto`` resolved: embedding for a Discrete / MultiDiscrete key, cnn
    for an image (3 dims), mlp otherwise."""
    if cfg.encoder == "auto":
        return "embedding" if is_discrete(space) else "cnn" if len(space.shape) == 3 else "mlp"
    return cfg.encoder


class MultiInputEncoder(nn.Module):
    """ObsDict {key: (B, *shape)} -> (B, out_size): each read key through its encoder, concatenated in the
    space's key order. ``keys`` lists the keys read (those whose encoder is not ``none``)."""

    def __init__(self, space: gym.spaces.Dict, inputs: dict[str, InputConfig], path: str = "params.network") -> None:
        super().__init__()
        # a key the network reads must be there; one set to encoder none may be absent (the same inputs block
        # can serve an env, or an actor and a critic, that lack it)
        unknown = [k for k, cfg in inputs.items() if k not in space.spaces and cfg.encoder != "none"]
        if unknown:
            raise ValueError(f"{path}.inputs: {', '.join(unknown)} not a key of the observations "
                             f"({', '.join(space.spaces)})")
        self.encoders = nn.ModuleDict()
        for key, sub in space.spaces.items():
            cfg = inputs.get(key, InputConfig())
            shape = tuple(sub.shape)
            kind = encoder_kind(cfg, sub)
            if kind == "none":
                continue
            if kind in ("cnn", "impala"):
                if len(shape) != 3 or is_discrete(sub):
                    raise ValueError(f"{path}.inputs.{key}.encoder: {kind} needs an image (C, H, W), '{key}' has "
                                     f"shape {shape}" + (f" ({type(sub).__name__})" if is_discrete(sub) else ""))
                self.encoders[key] = ImageEncoder(cfg, shape, kind)
            elif kind == "embedding":
                if not is_discrete(sub):
                    raise ValueError(f"{path}.inputs.{key}.encoder: embedding needs a Discrete or MultiDiscrete "
                                     f"key, '{key}' is {sub}")
                self.encoders[key] = EmbeddingEncoder(cfg, sub)
            else:
                self.encoders[key] = FlatEncoder(cfg, sub, kind)
        if not self.encoders:
            raise ValueError(f"{path}.inputs: every key is encoder none; the network reads nothing")
        self.keys = tuple(self.encoders)
        self.out_size = sum(e.out_size for e in self.encoders.values())

    def forward(self, obs: Any) -> torch.Tensor:
        return torch.cat([encoder(obs[key]) for key, encoder in self.encoders.items()], -1)


def multi_input_network(cfg: MultiInputNetworkConfig, **kwargs: Any) -> nn.Module:
    """The network registered as ``multi_input``: Dict observations kept per key (``takes_dict_obs``)."""
    space = kwargs.get("observation_space")
    if not is_dict_space(space):
        raise ValueError(f"params.network.name: multi_input needs Dict observations (an image, a vector ...), "
                         f"the env gives {space}")
    if kwargs.get("model_name") in OFF_POLICY_MODELS:  # SAC / DQN: their own heads on the same encoders
        return multi_input_off_policy(cfg, kwargs["model_name"], lambda: MultiInputEncoder(space, cfg.inputs),
                                      kwargs["actions_num"], isinstance(kwargs["action_space"], gym.spaces.Discrete))
    if cfg.dueling is not None:
        raise ValueError("params.network.dueling: a DQN head; only model dqn reads it (remove it)")
    continuous = is_continuous(cfg, kwargs["action_space"])
    return ActorCriticNetwork(cfg, (), kwargs["actions_num"], kwargs.get("value_size", 1), continuous,
                              lambda: MultiInputEncoder(space, cfg.inputs),
                              logits_sizes=logits_sizes(kwargs["action_space"]))


multi_input_network.config_class = MultiInputNetworkConfig
multi_input_network.takes_dict_obs = True
