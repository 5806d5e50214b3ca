"""The IMPALA residual encoder of ``resnet_actor_critic`` (Espeholt et al. 2018, as rl_games builds it).

Each stage of ``cnn.conv_depths``: conv 3x3 (stride 1, same padding) -> max-pool 3x3 stride 2
(padding 1, so H -> ceil(H / 2)) -> two residual blocks ``x + conv(act(conv(act(x))))``. After the
last stage the features are flattened and go through an activation once more (rl_games takes the
mlp's there, see :class:`ImpalaEncoder`).
"""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.network import ResnetCnnConfig
from rlchain.networks.layers import activation, initialize


class ConvBlock(nn.Module):
    """A 3x3 convolution (stride 1, same padding) held as ``conv``, rl_games' ``ConvBlock`` without batch norm."""

    def __init__(self, in_channels: int, out_channels: int) -> None:
        super().__init__()
        self.conv = nn.Conv2d(in_channels, out_channels, kernel_size=3, stride=1, padding=1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.conv(x)


class ResidualBlock(nn.Module):
    """(B, C, H, W) -> (B, C, H, W): ``x + conv2(act(conv1(act(x))))``."""

    def __init__(self, channels: int, act: str) -> None:
        super().__init__()
        self.activate1, self.conv1 = activation(act), ConvBlock(channels, channels)
        self.activate2, self.conv2 = activation(act), ConvBlock(channels, channels)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.conv2(self.activate2(self.conv1(self.activate1(x))))


class ImpalaStage(nn.Module):
    """(B, C_in, H, W) -> (B, C_out, ceil(H / 2), ceil(W / 2)); rl_games' ``ImpalaSequential`` names."""

    def __init__(self, in_channels: int, out_channels: int, act: str) -> None:
        super().__init__()
        self.conv = ConvBlock(in_channels, out_channels)
        self.max_pool = nn.MaxPool2d(kernel_size=3, stride=2, padding=1)
        self.res_block1 = ResidualBlock(out_channels, act)
        self.res_block2 = ResidualBlock(out_channels, act)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.res_block2(self.res_block1(self.max_pool(self.conv(x))))


class ImpalaEncoder(nn.Module):
    """(B, *input_shape) float -> (B, out_size) flat features: the stages held as ``0``, ``1``, ... (rl_games'
    ``cnn`` Sequential), then an activation.

    ``input_shape`` is (C, H, W), or (H, W, C) with ``permute_input`` (gymnasium image envs).
    Convolution weights: ``cnn.initializer``, or with ``default`` kaiming-normal (fan_out, relu),
    rl_games' choice for this network. ``cnn.activation`` acts inside the residual blocks,
    ``out_activation`` (default: the same) on the flattened features.
    """

    def __init__(self, cfg: ResnetCnnConfig, input_shape: tuple[int, ...], out_activation: str | None = None) -> None:
        super().__init__()
        shape = tuple(input_shape)
        if len(shape) != 3:
            raise ValueError(f"params.network.cnn: resnet_actor_critic needs image observations (C, H, W), or "
                             f"(H, W, C) with permute_input; the env gives {shape}")
        self.permute = cfg.permute_input
        if self.permute:
            shape = (shape[-1], *shape[:-1])
        channels, self.stages = shape[0], []
        for i, depth in enumerate(cfg.conv_depths):
            self.stages.append(ImpalaStage(channels, depth, cfg.activation))
            self.add_module(str(i), self.stages[-1])
            channels = depth
        self.out_act = activation(out_activation or cfg.activation)
        for module in self.modules():
            if isinstance(module, nn.Conv2d):
                if cfg.initializer.name in ("default", "None"):
                    nn.init.kaiming_normal_(module.weight, mode="fan_out", nonlinearity="relu")
                else:
                    initialize(module.weight, cfg.initializer)
                    nn.init.zeros_(module.bias)
        with torch.no_grad():
            self.out_size = int(self._stages(torch.zeros(1, *shape)).numel())

    def _stages(self, x: torch.Tensor) -> torch.Tensor:
        for stage in self.stages:
            x = stage(x)
        return x

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if self.permute:
            x = x.permute(0, 3, 1, 2)
        return self.out_act(self._stages(x).flatten(1))
