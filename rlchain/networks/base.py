"""The network-builder contract, the same shape as rl_games' so user builders port over.

A builder is registered with ``rlchain.model_builder.register_network(name, BuilderClass)``.
rlchain calls ``builder = BuilderClass(); builder.load(params_network); builder.build(name, **kwargs)``
with kwargs ``actions_num``, ``input_shape``, ``value_size``, ``num_seqs`` and ``action_space``.
The module's ``forward(input_dict)`` receives ``{'obs': (B, *obs_shape) tensor, ...}`` and returns
``(logits, value, states)`` for discrete actions or ``(mu, sigma, value, states)`` for continuous
ones; ``value`` has shape (B, value_size).
"""

from __future__ import annotations

from typing import Any

import torch.nn as nn


class NetworkBuilder:
    """Base class for network builders: keep the params in ``load``, make the module in ``build``."""

    config_class: type | None = None  # a dataclass to validate the network block against, if any

    def __init__(self, **kwargs: Any) -> None:
        self.params: Any = None

    def load(self, params: Any) -> None:
        """Receive the (validated) ``params.network`` block."""
        self.params = params

    def build(self, name: str, **kwargs: Any) -> nn.Module:  # pragma: no cover - interface
        raise NotImplementedError

    def __call__(self, name: str, **kwargs: Any) -> nn.Module:
        return self.build(name, **kwargs)


def instantiate(builder: Any, params: Any, **kwargs: Any) -> nn.Module:
    """Build a module from a registered builder: a NetworkBuilder-like class or a plain function."""
    if isinstance(builder, type):
        obj = builder()
        obj.load(params)
        return obj.build("network", **kwargs)
    return builder(params, **kwargs)
