"""The network-builder contract, the same shape as rl_games' so user builders port over.

A builder is registered with ``rlchain.model_builder.register_network(name, BuilderClass)``.
rlchain calls ``builder = BuilderClass(); builder.load(params_network); builder.build(name, **kwargs)``
with kwargs ``actions_num``, ``input_shape``, ``value_size``, ``num_seqs``, ``action_space`` and
``observation_space`` (the env's own space: for Dict observations, which arrive flattened, the Dict,
so the network can split them by key with ``rlchain.envs.dict_obs.split_flat_obs``).
The module's ``forward(input_dict)`` receives ``{'obs': (B, *obs_shape) tensor, ...}`` and returns
``(logits, value, states)`` for discrete actions or ``(mu, sigma, value, states)`` for continuous
ones; ``value`` has shape (B, value_size). As the critic of ``central_value_config.network`` it is
built from a block with ``central_value: True`` (``actions_num = value_size``, ``input_shape`` the
state's) and returns ``(value, states)``.

Optional, as in rl_games: ``get_aux_loss()`` returning ``{name: scalar tensor}`` (or None) from the
last ``forward``; PPO adds each loss to its loss (weight 1) and logs it as ``losses/<name>``
(example: :mod:`rlchain.networks.test_networks`).
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
