"""The convolutional encoder of the ``cnn:`` block: conv2d over images or conv1d over signals."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.network import CnnConfig
from rlchain.networks.layers import activation, initialize


class ConvEncoder(nn.Sequential):
    """(B, *input_shape) float -> (B, out_size) flat features: conv, activation, conv, ... in one Sequential,
    rl_games' layout (its ``actor_cnn.<i>``).

    With ``permute_input`` the input is channels-last, (H, W, C) or (L, C), as gymnasium image
    envs return it; otherwise channels-first, (C, H, W) or (C, L), as envpool Atari does.
    """

    def __init__(self, cfg: CnnConfig, input_shape: tuple[int, ...]) -> None:
        super().__init__()
        dims = 3 if cfg.type == "conv2d" else 2
        if len(input_shape) != dims:
            raise ValueError(f"params.network.cnn.type: {cfg.type} needs observations of {dims} dims "
                             f"({'(C, H, W)' if dims == 3 else '(C, L)'}), the env gives {tuple(input_shape)}")
        self.permute = cfg.permute_input
        shape = tuple(input_shape)
        if self.permute:
            shape = (shape[-1], *shape[:-1])
        conv = nn.Conv2d if cfg.type == "conv2d" else nn.Conv1d
        layers: list[nn.Module] = []
        channels = shape[0]
        for spec in cfg.convs:
            layer = conv(channels, spec.filters, spec.kernel_size, stride=spec.strides, padding=spec.padding)
            if cfg.initializer.name not in ("default", "None"):
                initialize(layer.weight, cfg.initializer)
                nn.init.zeros_(layer.bias)
            layers += [layer, activation(cfg.activation)]
            channels = spec.filters
        for layer in layers:
            self.append(layer)
        size = shape[1:]  # spatial size after each conv: (size + 2 * padding - kernel) // stride + 1
        for i, spec in enumerate(cfg.convs):
            size = tuple((s + 2 * spec.padding - spec.kernel_size) // spec.strides + 1 for s in size)
            if min(size) < 1:
                raise ValueError(f"params.network.cnn.convs[{i}]: the convolutions shrink the input "
                                 f"{tuple(input_shape)} to nothing; use smaller kernels or strides")
        with torch.no_grad():
            self.out_size = int(super().forward(torch.zeros(1, *shape)).numel())
        self._order = (0, dims, *range(1, dims)) if self.permute else None

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if self._order is not None:
            x = x.permute(*self._order)
        return super().forward(x).flatten(1)
