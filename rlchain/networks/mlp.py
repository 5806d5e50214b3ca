"""The fully connected trunk, optionally D2RL (input concatenated to every hidden layer)."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.network import MlpConfig
from rlchain.networks.layers import activation, linear


class MLP(nn.Module):
    """(B, in_size) -> (B, units[-1]); an empty ``units`` list is the identity. Each hidden layer is one
    Sequential: linear, norm, activation; or linear, activation, norm with ``norm_after_activation``."""

    def __init__(self, in_size: int, cfg: MlpConfig) -> None:
        super().__init__()
        self.d2rl = cfg.d2rl
        self.in_size = in_size
        layers = []
        size = in_size
        for i, units in enumerate(cfg.units):
            fan_in = size + (in_size if self.d2rl and i > 0 else 0)
            block = [linear(fan_in, units, cfg.initializer), activation(cfg.activation)]
            if cfg.normalization and (i == 0 or not cfg.norm_only_first_layer):
                norm = nn.LayerNorm(units) if cfg.normalization == "layer_norm" else nn.BatchNorm1d(units)
                block.insert(2 if cfg.norm_after_activation else 1, norm)
            if cfg.dropout > 0:
                block.append(nn.Dropout(cfg.dropout))
            layers.append(nn.Sequential(*block))
            size = units
        self.out_size = size
        if self.d2rl:
            self.layers = nn.ModuleList(layers)
        else:
            self.net = nn.Sequential(*layers)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not self.d2rl:
            return self.net(x)
        out = x
        for i, layer in enumerate(self.layers):
            out = layer(out if i == 0 else torch.cat([out, x], dim=-1))
        return out
