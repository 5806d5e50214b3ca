"""The network-builder contract, the same shape as rl_games' so user builders port over.

A builder is registered with ``rlchain.model_builder.register_network(name, builder)``: a function (or a
network class) ``builder(params_network, **kwargs) -> nn.Module``, or a class with rl_games' shape, which rlchain
calls as ``b = BuilderClass(); b.load(params_network); b.build(name, **kwargs)``; either way
with kwargs ``actions_num``, ``input_shape``, ``value_size``, ``num_seqs``, ``action_space`` and
``observation_space`` (the env's own space: for Dict observations, which arrive flattened, the Dict,
so the network can split them by key with ``rlchain.envs.wrappers.dict_obs.split_flat_obs``).
The module's ``forward(input_dict)`` receives ``{'obs': (B, *obs_shape) tensor, ...}`` and returns
``(logits, value, states)`` for discrete actions or ``(mu, sigma, value, states)`` for continuous
ones; ``value`` has shape (B, value_size). As the critic of ``central_value_config.network`` it is
built from a block with ``central_value: True`` (``actions_num = value_size``, ``input_shape`` the
state's) and returns ``(value, states)``.

Optional, as in rl_games: ``get_aux_loss()`` returning ``{name: scalar tensor}`` (or None) from the
last ``forward``; PPO adds each loss to its loss (weight 1) and logs it as ``losses/<name>``
(example: :mod:`rlchain.networks.example_networks`).
"""

from __future__ import annotations

import warnings
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
        """Make the module from ``self.params``; ``kwargs`` as the module docstring lists them
        (``actions_num``, ``input_shape``, ``value_size``, ``num_seqs``, ``action_space``,
        ``observation_space``). ``name`` is rl_games' argument (rlchain passes ``'network'``)."""
        raise NotImplementedError

    def __call__(self, name: str, **kwargs: Any) -> nn.Module:
        return self.build(name, **kwargs)


_KEYED = ("__getitem__", "get", "__contains__", "pop", "setdefault")
_BULK = ("__iter__", "keys", "items", "values")


def _marks_key(name: str) -> Any:
    """``dict.<name>(key, ...)`` that first marks ``key`` read."""
    method = getattr(dict, name)

    def marked(self: ReadKeys, key: Any, *args: Any) -> Any:
        self.read.add(key)
        return method(self, key, *args)
    return marked


def _marks_all(name: str) -> Any:
    """``dict.<name>()`` that first marks every key (nested blocks' too) read."""
    method = getattr(dict, name)

    def marked(self: ReadKeys) -> Any:
        self._all()
        return method(self)
    return marked


class ReadKeys(dict):
    """A network block (a plain dict) that records which of its keys, and its nested blocks' keys,
    the builder read, so keys it never looked at can be reported as likely typos.

    Reading a key (``[]``, ``get``, ``in``, ``pop``, ``setdefault``) marks it; iterating, copying or
    unpacking the block marks all its keys, so a builder that forwards the whole block is never blamed.
    """

    def __init__(self, block: dict) -> None:
        super().__init__({k: ReadKeys(v) if isinstance(v, dict) else v for k, v in block.items()})
        self.read: set = set()

    def _all(self) -> None:
        """Bulk access hands the nested blocks out too: everything under this block counts as read."""
        self.read.update(super().keys())
        for value in super().values():
            if isinstance(value, ReadKeys):
                value._all()

    # reading a key marks it; iterating or viewing the block marks every key
    __getitem__, get, __contains__, pop, setdefault = (_marks_key(name) for name in _KEYED)
    __iter__, keys, items, values = (_marks_all(name) for name in _BULK)

    def copy(self) -> dict:
        self._all()
        return dict(super().items())

    def unread(self, prefix: str = "") -> list[str]:
        """Dotted paths of the keys never read, nested blocks included."""
        out = []
        for key, value in super().items():
            if key not in self.read:
                out.append(f"{prefix}{key}")
            elif isinstance(value, ReadKeys):
                out += value.unread(f"{prefix}{key}.")
        return out


IGNORED_KEYS = ("name", "central_value")  # read by rlchain itself / added by rlchain for a critic


def instantiate(builder: Any, params: Any, path: str = "params.network", **kwargs: Any) -> nn.Module:
    """Build a module from a registered builder: a NetworkBuilder-like class (``load`` / ``build``) or a
    callable ``builder(block, **kwargs)`` (a function, a network class).

    A plain-dict block (a builder without ``config_class``) is checked after the build: keys the
    builder never read are a warning that names them (``path`` is the block's place in the config).
    """
    tracked = ReadKeys(params) if type(params) is dict else None
    block = tracked if tracked is not None else params
    if isinstance(builder, type) and callable(getattr(builder, "build", None)):
        obj = builder()
        obj.load(block)
        module = obj.build("network", **kwargs)
    else:
        module = builder(block, **kwargs)
    unread = [key for key in tracked.unread() if key not in IGNORED_KEYS] if tracked is not None else []
    if unread:
        warnings.warn(f"{path}: {', '.join(unread)} not read by network builder "
                      f"'{params.get('name', '?')}' (a typo? a builder's config_class makes unknown keys an "
                      f"error)", stacklevel=2)
    return module
