"""``DefaultPPOTorchRLModule``, PPO's default module written from RLlib's description, for subclasses (RLlib's
action-masking example derives from it); RLlib's path ``ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module``
names it. It lives here, outside the ``algorithms`` package, so :mod:`rlchain.rllib.module_network` imports it
without importing the algorithms (which import the module network).

``setup`` builds from ``model_config`` (RLlib's DefaultModelConfig keys): an encoder MLP of ``fcnet_hiddens`` with
``fcnet_activation`` (one trunk when ``vf_share_layers``, else a separate critic trunk), then the policy head and
the value head, each an MLP of ``head_fcnet_hiddens`` with ``head_fcnet_activation`` and a final linear layer.
``action_dist_inputs``: logits (Discrete), or means then log-stds (Box; ``free_log_std``: log-stds that do not
depend on the observation). Observations are flattened per row.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
from torch import nn

from rlchain.rllib import keys as K
from rlchain.rllib.core.columns import Columns
from rlchain.rllib.core.models.base import ACTOR, CRITIC, ENCODER_OUT
from rlchain.rllib.core.rl_module.apis import InferenceOnlyAPI, ValueFunctionAPI
from rlchain.rllib.core.rl_module.torch.torch_rl_module import TorchRLModule

_ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU, "elu": nn.ELU, "swish": nn.SiLU, "silu": nn.SiLU, "gelu": nn.GELU,
                "sigmoid": nn.Sigmoid, "selu": nn.SELU, "softplus": nn.Softplus, "linear": None, None: None}


def mlp(size: int, hiddens: list[int], activation: Any, out: int | None = None) -> tuple[nn.Module, int]:
    """(layers, output size): ``hiddens`` with ``activation`` after each, then a linear layer to ``out``."""
    if activation not in _ACTIVATIONS:
        raise ValueError(f"model_config activation {activation!r}: one of "
                         f"{', '.join(str(a) for a in _ACTIVATIONS if a)}")
    layers: list[nn.Module] = []
    for units in hiddens:
        layers.append(nn.Linear(size, int(units)))
        if _ACTIVATIONS[activation] is not None:
            layers.append(_ACTIVATIONS[activation]())
        size = int(units)
    if out is not None:
        layers.append(nn.Linear(size, out))
        size = out
    return nn.Sequential(*layers), size


class _Encoder(nn.Module):
    """{"obs": (B, ...)} -> {ENCODER_OUT: {ACTOR: (B, H), CRITIC: (B, H)}}; ``critic_encoder`` when not shared."""

    def __init__(self, size: int, hiddens: list[int], activation: Any, shared: bool) -> None:
        super().__init__()
        self.actor_encoder, self.out_size = mlp(size, hiddens, activation)
        if not shared:
            self.critic_encoder = _Trunk(mlp(size, hiddens, activation)[0])

    def forward(self, batch: dict[str, Any]) -> dict[str, Any]:
        obs = _flat(batch[Columns.OBS])
        actor = self.actor_encoder(obs)
        critic = self.critic_encoder.layers(obs) if hasattr(self, "critic_encoder") else actor
        return {ENCODER_OUT: {ACTOR: actor, CRITIC: critic}}


class _Trunk(nn.Module):
    """The critic's own trunk, callable on a batch as RLlib's ``encoder.critic_encoder`` is."""

    def __init__(self, layers: nn.Module) -> None:
        super().__init__()
        self.layers = layers

    def forward(self, batch: dict[str, Any]) -> dict[str, Any]:
        return {ENCODER_OUT: self.layers(_flat(batch[Columns.OBS]))}


class _FreeLogStd(nn.Module):
    """Means from the head, log-stds a learned vector (``free_log_std``)."""

    def __init__(self, head: nn.Module, dim: int) -> None:
        super().__init__()
        self.head = head
        self.log_std = nn.Parameter(torch.zeros(dim))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        mean = self.head(x)
        return torch.cat([mean, self.log_std.expand_as(mean)], -1)


def _flat(obs: Any) -> torch.Tensor:
    if isinstance(obs, dict):
        raise ValueError("DefaultPPOTorchRLModule takes flat (Box) observations; a Dict observation needs a "
                         "module that takes its keys apart (as RLlib's action-masking module does)")
    obs = torch.as_tensor(obs)
    return obs.reshape(obs.shape[0], -1).float()


class DefaultPPOTorchRLModule(TorchRLModule, ValueFunctionAPI, InferenceOnlyAPI):
    """PPO's default module: ``encoder``, ``pi``, ``vf`` (see the module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)

    def setup(self) -> None:
        cfg = {**K.DEFAULT_MODEL, **(self.model_config or {})}
        size = int(gym.spaces.flatdim(self.observation_space))
        self.encoder = _Encoder(size, list(cfg["fcnet_hiddens"] or []), cfg["fcnet_activation"],
                                bool(cfg["vf_share_layers"]))
        space = self.action_space
        if isinstance(space, gym.spaces.Discrete):
            outputs, free = int(space.n), False
        elif isinstance(space, gym.spaces.Box):
            dim = int(np.prod(space.shape))
            free = bool(cfg["free_log_std"])
            outputs = dim if free else 2 * dim
        else:
            raise ValueError(f"DefaultPPOTorchRLModule: {type(space).__name__} actions (Discrete or Box)")
        heads, head_act = list(cfg["head_fcnet_hiddens"] or []), cfg["head_fcnet_activation"]
        pi = mlp(self.encoder.out_size, heads, head_act, outputs)[0]
        self.pi = _FreeLogStd(pi, outputs) if free else pi
        self.vf = mlp(self.encoder.out_size, heads, head_act, 1)[0]

    def _forward(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        encoded = self.encoder(batch)[ENCODER_OUT]
        return {Columns.ACTION_DIST_INPUTS: self.pi(encoded[ACTOR])}

    def _forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        encoded = self.encoder(batch)[ENCODER_OUT]
        return {Columns.ACTION_DIST_INPUTS: self.pi(encoded[ACTOR]), Columns.EMBEDDINGS: encoded[CRITIC]}

    def compute_values(self, batch: dict[str, Any], embeddings: Any = None) -> torch.Tensor:
        if embeddings is None:
            embeddings = self.encoder(batch)[ENCODER_OUT][CRITIC]
        return self.vf(embeddings).squeeze(-1)

    def get_non_inference_attributes(self) -> list[str]:
        return ["vf"] + ([] if self.model_config.get("vf_share_layers") else ["encoder.critic_encoder"])


__all__ = ["DefaultPPOTorchRLModule"]
