"""The act step's pass through a plain MLP actor-critic, each layer's own forward called directly.

A rollout on a few CPU envs calls the network once per env step with a batch of a few rows, where
``nn.Module.__call__`` (hook checks, tracing state), the input dict, ``_trunk``'s layout branches and the
Sequential container cost as much as the matmuls. For :class:`ActorCriticNetwork` built from Linear layers
and activations only (no encoder, RNN, normalization, dropout or D2RL; the built-in heads), :class:`DirectPass`
runs the same layers' forward methods on the same inputs: the same floats, bit for bit. Any module with a
forward hook (or a global hook) makes the pass decline each call, so the module's own call (and its hooks)
runs instead.
"""

from __future__ import annotations

import torch
import torch.nn as nn
from torch.nn.modules import module as nn_module

from rlchain.networks.actor_critic import ActorCriticNetwork
from rlchain.networks.layers import ACTIVATIONS, Linear
from rlchain.networks.mlp import MLP

_ACTIVATION_TYPES = frozenset(ACTIVATIONS.values())
"""Activations whose forward is one elementwise function of the input."""
_LINEAR_TYPES = frozenset({nn.Linear, Linear})


class DirectPass:
    """obs (B, features) -> ``network``'s output tuple, (logits, value, None) or (mu, sigma, value, None),
    through the same layers' forward methods; :attr:`plain` False when ``network`` is not a plain MLP
    actor-critic. A plain object holding the modules (not a closure), so a deep copy of the model that holds
    it runs the copy's layers."""

    def __init__(self, network: nn.Module) -> None:
        self.network = network
        self.plain = False
        if type(network) is not ActorCriticNetwork or network.central_value or network.is_rnn() \
                or network.has_heads or "forward" in network.__dict__:  # has_heads: per-stream hidden layers
            return
        trunks = [_plain_layers(network, network.actor_layout)]
        if network.critic_layout is not None:
            trunks.append(_plain_layers(network, network.critic_layout))
        self.continuous = continuous = network.continuous
        self.fixed_sigma = continuous and network.fixed_sigma
        names = ("value", "mu") + (() if self.fixed_sigma else ("sigma",)) if continuous else ("value", "logits")
        heads = [network._modules.get(name) for name in names]
        acts = [network.value_act] + ([network.mu_act, network.sigma_act] if continuous else [])
        if any(t is None for t in trunks) or any(type(h) not in _LINEAR_TYPES for h in heads) \
                or any(type(a) not in _ACTIVATION_TYPES for a in acts):
            return
        self.actor, self.critic = trunks[0], trunks[-1] if len(trunks) > 1 else None
        self.heads, self.acts = heads, acts
        mlps = [network._modules[layout.mlp] for layout in (network.actor_layout, network.critic_layout) if layout]
        self.modules = [network, *mlps, *(m for t in trunks for m in t), *heads, *acts]
        # the containers' children as built: a module replaced later makes every call decline
        self.children = [(m._modules, dict(m._modules)) for m in (network, *mlps)]
        self.plain = True

    def __call__(self, obs: torch.Tensor) -> tuple | None:
        """The network's output for ``obs`` (already preprocessed), or None when a forward hook is set (global
        or on one of the modules) or a module was replaced: the caller then runs the module's own call."""
        if _hooked(self.modules) or any(live != built for live, built in self.children):
            return None
        x = obs if type(obs) is torch.Tensor and obs.dim() == 2 else obs.flatten(1)
        a_out = _run(self.actor, x)
        c_out = _run(self.critic, x) if self.critic is not None else a_out
        heads, acts = self.heads, self.acts
        value = acts[0].forward(heads[0].forward(c_out))
        if not self.continuous:
            return heads[1].forward(a_out), value, None
        mu = acts[1].forward(heads[1].forward(a_out))
        if self.fixed_sigma:
            sigma = acts[2].forward(self.network.sigma).expand_as(mu)
        else:
            sigma = acts[2].forward(heads[2].forward(a_out))
        return mu, sigma, value, None


def _run(layers: list[nn.Module], x: torch.Tensor) -> torch.Tensor:
    for layer in layers:
        x = layer.forward(x)
    return x


def _plain_layers(network: ActorCriticNetwork, layout: object) -> list[nn.Module] | None:
    """The trunk's layers in order when it is an MLP of Linear layers and activations only, else None."""
    if layout.cnn is not None or layout.rnn is not None or layout.norm is not None:
        return None
    mlp = network._modules.get(layout.mlp)
    if type(mlp) is not MLP or mlp.d2rl:
        return None
    layers = list(mlp)
    if any(type(m) not in _LINEAR_TYPES and type(m) not in _ACTIVATION_TYPES for m in layers):
        return None
    return layers


def _hooked(modules: list[nn.Module]) -> bool:
    """Whether a forward hook (global or on one of ``modules``) is set: then the modules' own calls run."""
    if nn_module._global_forward_hooks or nn_module._global_forward_pre_hooks:
        return True
    return any(m._forward_hooks or m._forward_pre_hooks for m in modules)
