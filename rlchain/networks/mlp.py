"""The fully connected trunk as rl_games builds it (one Sequential), optionally D2RL."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.network import MlpConfig
from rlchain.networks.layers import activation, linear


class MLP(nn.Sequential):
    """(B, in_size) -> (B, out_size); an empty ``units`` list (and no ``output``) is the identity.

    The layers sit in one Sequential, rl_games' layout (so its ``actor_mlp.<i>`` keys are this module's): per
    hidden layer linear, activation and, with a normalization, the norm after the activation
    (``norm_after_activation``, rl_games') or between linear and activation (rlchain's default); a dropout last.
    ``output``: a final linear layer of that size in the same Sequential (rl_games' SAC actor and critics).
    D2RL (the input concatenated to every hidden layer after the first) keeps one Sequential per layer instead.
    """

    def __init__(self, in_size: int, cfg: MlpConfig, output: int | None = None) -> None:
        super().__init__()
        self.d2rl = cfg.d2rl
        self.in_size = in_size
        blocks = []
        size = in_size
        for i, units in enumerate(cfg.units):
            fan_in = size + (in_size if self.d2rl and i > 0 else 0)
            block = [linear(fan_in, units, cfg.initializer), activation(cfg.activation)]
            if cfg.normalization and (i == 0 or not cfg.norm_only_first_layer):
                norm = nn.LayerNorm(units) if cfg.normalization == "layer_norm" else nn.BatchNorm1d(units)
                block.insert(2 if cfg.norm_after_activation else 1, norm)
            if cfg.dropout > 0:
                block.append(nn.Dropout(cfg.dropout))
            blocks.append(nn.Sequential(*block) if self.d2rl else block)
            size = units
        for module in (blocks if self.d2rl else [m for block in blocks for m in block]):
            self.append(module)
        if output is not None:
            self.append(linear(size, output, cfg.initializer))
            size = output
        self.hidden = len(blocks)
        self.out_size = size

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not self.d2rl:
            return super().forward(x)
        out = x
        for i, layer in enumerate(self):
            out = layer(out if i == 0 or i >= self.hidden else torch.cat([out, x], dim=-1))
        return out
