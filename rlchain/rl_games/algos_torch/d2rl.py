"""rl_games' ``algos_torch.d2rl``: ``D2RLNet``, the MLP of D2RL (each hidden layer after the first also reads the
network's input), as network builders written for rl_games import it (PHC's, for one). The same parameter names
as rl_games' (``linears``, ``norm_layers``, ``activations``), so their checkpoints load; rlchain's own networks
take ``mlp.d2rl: True`` instead.
"""

from __future__ import annotations

import torch
from torch import nn


class D2RLNet(nn.Module):
    """``input_size`` -> ``units[-1]``: layer 0 is linear, activation, norm; layer i > 0 reads ``[x, input]``
    and is linear, norm, activation (rl_games' order). ``norm_func_name``: ``layer_norm``, ``batch_norm`` or
    None."""

    def __init__(self, input_size: int, units: list[int], activations: list[nn.Module],
                 norm_func_name: str | None = None) -> None:
        super().__init__()
        if len(activations) != len(units):
            raise ValueError(f"D2RLNet: {len(units)} layers need as many activations, got {len(activations)}")
        self.activations = nn.ModuleList(activations)
        self.linears = nn.ModuleList()
        self.norm_layers = nn.ModuleList()
        self.num_layers = len(units)
        size = input_size
        for width in units:
            self.linears.append(nn.Linear(size, width))
            size = width + input_size
            if norm_func_name == "layer_norm":
                self.norm_layers.append(nn.LayerNorm(width))
            elif norm_func_name == "batch_norm":
                self.norm_layers.append(nn.BatchNorm1d(width))
            else:
                self.norm_layers.append(nn.Identity())

    def forward(self, input: torch.Tensor) -> torch.Tensor:  # noqa: A002  (rl_games' argument name)
        x = self.norm_layers[0](self.activations[0](self.linears[0](input)))
        for i in range(1, self.num_layers):
            x = self.activations[i](self.norm_layers[i](self.linears[i](torch.cat([x, input], dim=1))))
        return x
