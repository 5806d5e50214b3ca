"""Networks for the off-policy algorithms: ``soft_actor_critic`` (actor + twin critics) and ``dqn``.

Both follow the builder contract of :mod:`rlchain.networks.base` and read rl_games' network block
keys (``mlp.units / activation / initializer``, ``log_std_bounds``; ``dueling`` for DQN).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn

from rlchain.config.network import MlpConfig
from rlchain.config.off_policy import DQNNetworkConfig, SACNetworkConfig
from rlchain.networks.base import NetworkBuilder
from rlchain.networks.layers import linear
from rlchain.networks.mlp import MLP


class SACActor(nn.Module):
    """obs (B, obs_dim) -> (mu, log_std), each (B, A); log_std squashed into ``log_std_bounds``."""

    def __init__(self, obs_dim: int, actions_num: int, mlp: MlpConfig, log_std_bounds: list[float],
                 mean_clip: float | None = None) -> None:
        super().__init__()
        self.trunk = MLP(obs_dim, mlp)
        self.head = linear(self.trunk.out_size, 2 * actions_num, mlp.initializer)
        self.log_std_bounds = (float(log_std_bounds[0]), float(log_std_bounds[1]))
        self.mean_clip = None if mean_clip is None else float(mean_clip)

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        mu, log_std = self.head(self.trunk(obs)).chunk(2, dim=-1)
        if self.mean_clip is not None:  # SB3's Hardtanh on the gSDE actor's mean
            mu = mu.clamp(-self.mean_clip, self.mean_clip)
        low, high = self.log_std_bounds
        log_std = low + 0.5 * (high - low) * (torch.tanh(log_std) + 1.0)  # rl_games' soft bound
        return mu, log_std


class TwinQCritic(nn.Module):
    """(obs (B, obs_dim), actions (B, A)) -> (q1, q2), each (B,)."""

    def __init__(self, obs_dim: int, actions_num: int, mlp: MlpConfig) -> None:
        super().__init__()
        self.q1 = nn.Sequential(MLP(obs_dim + actions_num, mlp))
        self.q1.append(linear(self.q1[0].out_size, 1, mlp.initializer))
        self.q2 = nn.Sequential(MLP(obs_dim + actions_num, mlp))
        self.q2.append(linear(self.q2[0].out_size, 1, mlp.initializer))

    def forward(self, obs: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.cat([obs, actions], dim=-1)
        return self.q1(x).squeeze(-1), self.q2(x).squeeze(-1)


class SACNetwork(nn.Module):
    """``actor`` and ``critic`` (twin Q) submodules; ``forward`` is rl_games' ``(mu, log_std, None, None)``."""

    def __init__(self, cfg: SACNetworkConfig, input_shape: tuple[int, ...], actions_num: int) -> None:
        super().__init__()
        obs_dim = int(np.prod(input_shape))
        mlp = cfg.mlp
        if cfg.normalization is not None and mlp.normalization is None:  # rl_games 2.0: actor and critics
            mlp = dataclasses.replace(mlp, normalization=cfg.normalization)
        self.actor = SACActor(obs_dim, actions_num, mlp, cfg.log_std_bounds, cfg.mean_clip)
        self.critic = TwinQCritic(obs_dim, actions_num, mlp)

    def forward(self, input_dict: dict[str, Any]) -> tuple:
        mu, log_std = self.actor(input_dict["obs"].flatten(1))
        return mu, log_std, None, None

    def is_rnn(self) -> bool:
        return False


class SACNetworkBuilder(NetworkBuilder):
    """Builder registered as ``soft_actor_critic``."""

    config_class = SACNetworkConfig

    def build(self, name: str, **kwargs: Any) -> nn.Module:
        if not isinstance(kwargs["action_space"], gym.spaces.Box):
            raise ValueError(f"params.network: soft_actor_critic needs continuous (Box) actions, the env has "
                             f"{kwargs['action_space']}")
        return SACNetwork(self.params, tuple(kwargs["input_shape"]), kwargs["actions_num"])


class QNetwork(nn.Module):
    """obs (B, *input_shape) -> Q-values (B, actions_num); dueling: V + A - mean(A)."""

    def __init__(self, cfg: DQNNetworkConfig, input_shape: tuple[int, ...], actions_num: int) -> None:
        super().__init__()
        self.trunk = MLP(int(np.prod(input_shape)), cfg.mlp)
        size = self.trunk.out_size
        self.dueling = cfg.dueling
        self.advantage = linear(size, actions_num, cfg.mlp.initializer)
        self.state_value = linear(size, 1, cfg.mlp.initializer) if cfg.dueling else None

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        h = self.trunk(obs.flatten(1))
        adv = self.advantage(h)
        if self.state_value is None:
            return adv
        return self.state_value(h) + adv - adv.mean(-1, keepdim=True)

    def is_rnn(self) -> bool:
        return False


class QNetworkBuilder(NetworkBuilder):
    """Builder registered as ``dqn``."""

    config_class = DQNNetworkConfig

    def build(self, name: str, **kwargs: Any) -> nn.Module:
        if not isinstance(kwargs["action_space"], gym.spaces.Discrete):
            raise ValueError(f"params.network: dqn needs Discrete actions, the env has {kwargs['action_space']}")
        return QNetwork(self.params, tuple(kwargs["input_shape"]), kwargs["actions_num"])
