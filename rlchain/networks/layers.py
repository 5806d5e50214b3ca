"""Activations and initializers by their rl_games names."""

from __future__ import annotations

import math
from collections.abc import Callable

import torch
import torch.nn as nn
import torch.nn.functional as F

from rlchain.config.network import InitializerConfig

ACTIVATIONS: dict[str, Callable[..., nn.Module]] = {
    "relu": nn.ReLU, "tanh": nn.Tanh, "sigmoid": nn.Sigmoid, "elu": nn.ELU, "selu": nn.SELU,
    "swish": nn.SiLU, "silu": nn.SiLU, "gelu": nn.GELU, "softplus": nn.Softplus,
    "leaky_relu": nn.LeakyReLU, "mish": nn.Mish, "identity": nn.Identity, "None": nn.Identity,
}
"""Activation classes by rl_games' names (rl_games' ``activations_factory`` registers the same)."""


def activation(name: str | None) -> nn.Module:
    """A fresh activation module for ``name`` (``None``/'None' is the identity)."""
    return ACTIVATIONS[name if name is not None else "None"]()


def initialize(weight: torch.Tensor, cfg: InitializerConfig) -> None:
    """Initialize ``weight`` in place as rl_games' initializer of the same name would."""
    name = cfg.name
    with torch.no_grad():
        if name in ("default", "None"):
            return
        if name == "const_initializer":
            weight.fill_(cfg.val)
        elif name == "orthogonal_initializer":
            nn.init.orthogonal_(weight, gain=cfg.gain)
        elif name in ("glorot_normal_initializer", "xavier_normal"):
            nn.init.xavier_normal_(weight, gain=cfg.gain)
        elif name in ("glorot_uniform_initializer", "xavier_uniform"):
            nn.init.xavier_uniform_(weight, gain=cfg.gain)
        elif name == "random_uniform_initializer":
            nn.init.uniform_(weight, a=cfg.a, b=cfg.b)
        elif name == "kaiming_normal":
            nn.init.kaiming_normal_(weight, mode=_fan(cfg.mode), nonlinearity=cfg.nonlinearity)
        elif name == "kaiming_uniform":
            nn.init.kaiming_uniform_(weight, mode=_fan(cfg.mode), nonlinearity=cfg.nonlinearity)
        elif name == "variance_scaling_initializer":
            _variance_scaling(weight, cfg)
        else:  # pragma: no cover - the schema's choices forbid it
            raise ValueError(f"unknown initializer {name}")


def _fan(mode: str) -> str:
    return "fan_out" if mode == "fan_out" else "fan_in"


def _variance_scaling(weight: torch.Tensor, cfg: InitializerConfig) -> None:
    fan_in, fan_out = nn.init._calculate_fan_in_and_fan_out(weight)
    fan = {"fan_in": fan_in, "fan_out": fan_out, "fan_avg": (fan_in + fan_out) / 2}[cfg.mode]
    variance = cfg.scale / max(1.0, fan)
    if cfg.distribution == "uniform":
        bound = math.sqrt(3.0 * variance)
        nn.init.uniform_(weight, -bound, bound)
    elif cfg.distribution == "truncated_normal":
        std = math.sqrt(variance) / 0.87962566103423978
        nn.init.trunc_normal_(weight, std=std, a=-2 * std, b=2 * std)
    else:
        nn.init.normal_(weight, std=math.sqrt(variance))


NARROW_INPUTS = 12
"""Input widths up to which :class:`Linear` passes its weight to the matmul as an (in, out) copy on a CPU."""


class Linear(nn.Linear):
    """``nn.Linear`` with the same parameters and state dict, faster to train on a CPU with a narrow input.

    For ``F.linear(x, W, b)`` autograd computes the weight gradient in the layout of ``W.t()``, as
    ``(g.t() @ x).t()``: for an observation layer (x of B x 3 .. 12) that is a (out x B) @ (B x in) product,
    which MKL runs far below the core's matmul speed. Passing the weight as a contiguous (in, out) copy
    makes it ``x.t() @ g`` instead, several times faster for such narrow inputs; the forward pass
    gives the same values, the gradient the same sum in another order (float rounding). Only while a
    gradient is taken on a CPU: inference, export and CUDA run ``F.linear`` as before.
    """

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        # grad mode first: an act step (no gradient) leaves after one check
        if (torch.is_grad_enabled() and self.in_features <= NARROW_INPUTS and self.bias is not None
                and x.dim() == 2 and x.device.type == "cpu" and self.weight.requires_grad
                and not torch.jit.is_tracing()):  # a trace records one graph: F.linear, whatever the grad mode
            return torch.addmm(self.bias, x, self.weight.t().contiguous())
        return F.linear(x, self.weight, self.bias)


def linear(in_features: int, out_features: int, init: InitializerConfig) -> nn.Linear:
    """A Linear layer with the named weight initializer and zero bias (torch default when 'default')."""
    layer = Linear(in_features, out_features)
    if init.name not in ("default", "None"):
        initialize(layer.weight, init)
        nn.init.zeros_(layer.bias)
    return layer
