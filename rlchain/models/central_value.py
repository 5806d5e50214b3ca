"""The asymmetric critic: a value-only network on the env's full ``state`` (``central_value_config``)."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.config.schema import NetworkConfig
from rlchain.models.base import ObservationModel
from rlchain.models.normalization import RunningMeanStd
from rlchain.networks.actor_critic import Trunk
from rlchain.networks.layers import activation, linear


class CentralValueNetwork(nn.Module):
    """state (B, *state_shape) -> value (B, value_size): a trunk (cnn, mlp) and a linear value head."""

    def __init__(self, cfg: NetworkConfig, state_shape: tuple[int, ...], value_size: int) -> None:
        super().__init__()
        self.trunk = Trunk(cfg, state_shape)
        self.value = linear(self.trunk.out_size, value_size, cfg.mlp.initializer)
        self.value_act = activation(cfg.value_activation)

    def forward(self, state: torch.Tensor) -> torch.Tensor:
        features, _ = self.trunk(state, (), None, 1)
        return self.value_act(self.value(features))


class CentralValue(ObservationModel):
    """Critic model: state normalization, the network, and value normalization (raw <-> normalized)."""

    def __init__(self, cfg: NetworkConfig, state_shape: tuple[int, ...], value_size: int,
                 normalize_input: bool, normalize_value: bool) -> None:
        super().__init__()
        self.network = CentralValueNetwork(cfg, state_shape, value_size)
        self.obs_norm = RunningMeanStd(state_shape) if normalize_input else None
        self.value_norm = RunningMeanStd((value_size,), clip=0.0) if normalize_value else None

    def forward(self, state: torch.Tensor) -> torch.Tensor:
        """Values in the normalized space (B, value_size)."""
        return self.network(self.preprocess(state))

    @torch.inference_mode()
    def value(self, state: torch.Tensor) -> torch.Tensor:
        """Raw-scale values (B, value_size) for the rollout and GAE."""
        return self.denorm_value(self(state))

    def denorm_value(self, value: torch.Tensor) -> torch.Tensor:
        return self.value_norm.denormalize(value) if self.value_norm is not None else value

    def norm_value(self, value: torch.Tensor) -> torch.Tensor:
        return self.value_norm.normalize(value) if self.value_norm is not None else value

    def update_normalizers(self, obs: torch.Tensor | None = None, returns: torch.Tensor | None = None) -> None:
        """Fold states / raw returns into the running statistics."""
        super().update_normalizers(obs=obs)
        if returns is not None and self.value_norm is not None:
            self.value_norm.update(returns)
