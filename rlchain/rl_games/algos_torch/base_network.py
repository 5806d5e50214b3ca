"""rl_games' ``NetworkBuilder.BaseNetwork``: the module base class user networks subclass, with its layer helpers.

A subclass builds its layers with ``_build_mlp`` / ``_build_conv`` / ``_build_rnn`` / ``_build_value_layer``,
measures a conv stack with ``_calc_input_size``, and makes activations and weight initializers by rl_games'
names through ``self.activations_factory.create(name)`` and ``self.init_factory.create(name=..., **args)``
(the latter returns a function applied to a weight in place). The layouts (module order inside the
Sequentials, ``rnn.rnn`` for recurrent layers) are rl_games', so its checkpoints' keys match.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import torch
import torch.nn as nn

from rlchain.networks.layers import ACTIVATIONS
from rlchain.rl_games.algos_torch import layers
from rlchain.rl_games.algos_torch.d2rl import D2RLNet
from rlchain.rl_games.common.layers.recurrent import GRUWithDones, LSTMWithDones
from rlchain.rl_games.common.object_factory import ObjectFactory


def variance_scaling_initializer(tensor: torch.Tensor, mode: str = "fan_in", scale: float = 2.0) -> torch.Tensor:
    """Normal(0, sqrt(scale / fan)) truncated at two standard deviations (rl_games' defaults: fan_in, 2.0)."""
    fan = nn.init._calculate_correct_fan(tensor, mode)
    std = math.sqrt(scale / fan)
    return nn.init.trunc_normal_(tensor, std=std, a=-2 * std, b=2 * std)


def _const(tensor: torch.Tensor, val: float = 0.0, value: float | None = None, **_: Any) -> torch.Tensor:
    return nn.init.constant_(tensor, val if value is None else value)


def _keep(tensor: torch.Tensor, **_: Any) -> torch.Tensor:
    return tensor


INITIALIZERS: dict[str, Callable[..., torch.Tensor]] = {
    "const_initializer": _const, "orthogonal_initializer": nn.init.orthogonal_, "orthogonal": nn.init.orthogonal_,
    "glorot_normal_initializer": nn.init.xavier_normal_, "glorot_uniform_initializer": nn.init.xavier_uniform_,
    "variance_scaling_initializer": variance_scaling_initializer, "random_uniform_initializer": nn.init.uniform_,
    "kaiming_normal": nn.init.kaiming_normal_, "default": _keep,
}


def _initializer(func: Callable[..., torch.Tensor]) -> Callable[..., Callable[[torch.Tensor], torch.Tensor]]:
    """A factory builder: ``create(name, **args)`` -> a function of the weight alone."""
    return lambda **kwargs: (lambda tensor: func(tensor, **kwargs))


class IdentityRNN(nn.Module):
    """``rnn.name: identity``: the features pass through, the state is handed back unchanged."""

    def __init__(self, in_shape: int, out_shape: int) -> None:
        super().__init__()
        if in_shape != out_shape:
            raise ValueError(f"rnn.name: identity needs units ({out_shape}) equal to its input size ({in_shape})")

    def forward(self, x: torch.Tensor, h: Any, *_: Any) -> tuple[torch.Tensor, Any]:
        return x, h


def _norm_1d(name: str | None, size: int) -> nn.Module | None:
    if name == "layer_norm":
        return nn.LayerNorm(size)
    if name == "batch_norm":
        return nn.BatchNorm1d(size)
    return None


class LayerNorm2d(nn.Module):
    """LayerNorm over the channels of (B, C, H, W) maps (rl_games' conv normalization)."""

    def __init__(self, num_channels: int, eps: float = 1e-5) -> None:
        super().__init__()
        self.norm = nn.LayerNorm(num_channels, eps=eps)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.norm(x.permute(0, 2, 3, 1)).permute(0, 3, 1, 2)


class BaseNetwork(nn.Module):
    """The base of rl_games-style networks: rl_games' defaults for the optional methods plus layer helpers."""

    def __init__(self, **kwargs: Any) -> None:
        nn.Module.__init__(self, **kwargs)
        self.activations_factory = ObjectFactory()
        for name, cls in ACTIVATIONS.items():
            self.activations_factory.register_builder(name, cls)
        self.init_factory = ObjectFactory()
        for name, func in INITIALIZERS.items():
            self.init_factory.register_builder(name, _initializer(func))

    def _load_mlp_block(self, params: Any, separate: bool) -> None:
        """The network-block keys every rl_games network reads (``separate`` defaulting to ``separate``, the
        ``mlp`` block, ``value_activation``, ``normalization``) into the attributes rl_games names them by."""
        self.separate = params.get("separate", separate)
        mlp = params["mlp"]
        self.units = mlp["units"]
        self.activation = mlp["activation"]
        self.initializer = mlp["initializer"]
        self.is_d2rl = mlp.get("d2rl", False)
        self.norm_only_first_layer = mlp.get("norm_only_first_layer", False)
        self.value_activation = params.get("value_activation", "None")
        self.normalization = params.get("normalization", None)

    def is_separate_critic(self) -> bool:
        return False

    def get_value_layer(self) -> nn.Module | None:
        return getattr(self, "value", None)

    def is_rnn(self) -> bool:
        return False

    def get_default_rnn_state(self) -> tuple[torch.Tensor, ...] | None:
        return None

    def get_aux_loss(self) -> dict[str, torch.Tensor] | None:
        return None

    def _calc_input_size(self, input_shape: Sequence[int], cnn_layers: nn.Module | Sequence[nn.Module] | None = None
                         ) -> int:
        """Features out of ``cnn_layers`` for one observation of ``input_shape`` (the flat size without them)."""
        if cnn_layers is None:
            if len(input_shape) != 1:
                raise ValueError(f"_calc_input_size: a flat observation shape was expected, got {tuple(input_shape)}")
            return int(input_shape[0])
        stack = cnn_layers if isinstance(cnn_layers, nn.Module) else nn.Sequential(*cnn_layers)
        if isinstance(stack, nn.Sequential) and len(stack) == 0:
            return int(math.prod(input_shape))
        with torch.no_grad():
            return int(stack(torch.rand(1, *input_shape)).flatten(1).shape[1])

    def _noisy_dense(self, inputs: int, units: int) -> nn.Module:
        return layers.NoisyFactorizedLinear(inputs, units)

    def _build_rnn(self, name: str, input: int, units: int, layers: int) -> nn.Module:
        if name == "identity":
            return IdentityRNN(input, units)
        if name == "lstm":
            return LSTMWithDones(input_size=input, hidden_size=units, num_layers=layers)
        if name == "gru":
            return GRUWithDones(input_size=input, hidden_size=units, num_layers=layers)
        raise ValueError(f"params.network.rnn.name: expected lstm, gru or identity, got {name!r}")

    def _build_sequential_mlp(self, input_size: int, units: Sequence[int], activation: str,
                              dense_func: Callable[[int, int], nn.Module], norm_only_first_layer: bool = False,
                              norm_func_name: str | None = None) -> nn.Sequential:
        """Linear, activation[, norm] per entry of ``units`` (norm on the first layer only when asked)."""
        modules: list[nn.Module] = []
        size = input_size
        for i, unit in enumerate(units):
            modules += [dense_func(size, unit), self.activations_factory.create(activation)]
            norm = _norm_1d(norm_func_name, unit) if (i == 0 or not norm_only_first_layer) else None
            if norm is not None:
                modules.append(norm)
            size = unit
        return nn.Sequential(*modules)

    def _build_mlp(self, input_size: int, units: Sequence[int], activation: str,
                   dense_func: Callable[[int, int], nn.Module], norm_only_first_layer: bool = False,
                   norm_func_name: str | None = None, d2rl: bool = False) -> nn.Module:
        if d2rl:
            acts = [self.activations_factory.create(activation) for _ in units]
            return D2RLNet(input_size, units, acts, norm_func_name)
        return self._build_sequential_mlp(input_size, units, activation, dense_func,
                                          norm_only_first_layer=norm_only_first_layer, norm_func_name=norm_func_name)

    def _build_conv(self, ctype: str, **kwargs: Any) -> nn.Module:
        if ctype == "conv2d":
            return self._build_cnn2d(**kwargs)
        if ctype == "conv2d_flatten":
            return self._build_cnn2d(add_flatten=True, **kwargs)
        if ctype == "conv1d":
            return self._build_cnn1d(**kwargs)
        raise ValueError(f"params.network.cnn.type: expected conv2d, conv2d_flatten or conv1d, got {ctype!r}")

    def _build_cnn2d(self, input_shape: Sequence[int], convs: Sequence[dict], activation: str,
                     conv_func: Callable[..., nn.Module] = nn.Conv2d, norm_func_name: str | None = None,
                     add_flatten: bool = False) -> nn.Sequential:
        """Conv, activation[, norm] per entry of ``convs`` ({filters, kernel_size, strides, padding})."""
        channels = input_shape[0]
        modules: list[nn.Module] = []
        for conv in convs:
            modules += [conv_func(in_channels=channels, out_channels=conv["filters"], kernel_size=conv["kernel_size"],
                                  stride=conv["strides"], padding=conv["padding"]),
                        self.activations_factory.create(activation)]
            channels = conv["filters"]
            if norm_func_name == "layer_norm":
                modules.append(LayerNorm2d(channels))
            elif norm_func_name == "batch_norm":
                modules.append(nn.BatchNorm2d(channels))
        if add_flatten:
            modules.append(nn.Flatten())
        return nn.Sequential(*modules)

    def _build_cnn1d(self, input_shape: Sequence[int], convs: Sequence[dict], activation: str,
                     norm_func_name: str | None = None) -> nn.Sequential:
        channels = input_shape[0]
        modules: list[nn.Module] = []
        for conv in convs:
            modules += [nn.Conv1d(channels, conv["filters"], conv["kernel_size"], conv["strides"], conv["padding"]),
                        self.activations_factory.create(activation)]
            channels = conv["filters"]
            norm = _norm_1d(norm_func_name, channels)
            if norm is not None:
                modules.append(norm)
        return nn.Sequential(*modules)

    def _build_value_layer(self, input_size: int, output_size: int, value_type: str = "legacy") -> nn.Module:
        if value_type == "legacy":
            return nn.Linear(input_size, output_size)
        raise ValueError(f"params.network.value_type: {value_type!r} is not supported by rlchain (legacy only)")
