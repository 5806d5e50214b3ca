"""The built-in ``actor_critic`` network: MLP trunk (shared or separate) + action head + value head."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn

from rlchain.config.schema import NetworkConfig
from rlchain.networks.base import NetworkBuilder
from rlchain.networks.layers import activation, initialize, linear
from rlchain.networks.mlp import MLP


class ActorCriticNetwork(nn.Module):
    """Returns rl_games' tuple: ``(logits, value, None)`` or ``(mu, sigma, value, None)``.

    Shapes: obs (B, *input_shape) -> logits (B, actions_num) | mu, sigma (B, actions_num);
    value (B, value_size).
    """

    def __init__(self, cfg: NetworkConfig, input_shape: tuple[int, ...], actions_num: int,
                 value_size: int, continuous: bool) -> None:
        super().__init__()
        in_size = int(np.prod(input_shape))
        self.separate = cfg.separate
        self.actor_mlp = MLP(in_size, cfg.mlp)
        self.critic_mlp = MLP(in_size, cfg.mlp) if cfg.separate else None
        out = self.actor_mlp.out_size
        self.value = linear(out, value_size, cfg.mlp.initializer)
        self.value_act = activation(cfg.value_activation)
        self.continuous = continuous
        if continuous:
            space = cfg.space.continuous
            # rl_games: every Linear gets the mlp initializer (zero bias), then mu_init on top
            self.mu = linear(out, actions_num, cfg.mlp.initializer)
            initialize(self.mu.weight, space.mu_init)
            self.mu_act = activation(space.mu_activation)
            self.sigma_act = activation(space.sigma_activation)
            self.fixed_sigma = space.fixed_sigma
            if self.fixed_sigma:
                self.sigma = nn.Parameter(torch.zeros(actions_num))
                initialize(self.sigma.data.view(1, -1), space.sigma_init)
            else:
                self.sigma = linear(out, actions_num, cfg.mlp.initializer)
                initialize(self.sigma.weight, space.sigma_init)
        else:
            self.logits = linear(out, actions_num, cfg.mlp.initializer)

    def forward(self, input_dict: dict[str, Any]) -> tuple:
        obs = input_dict["obs"].flatten(1)
        a_out = self.actor_mlp(obs)
        c_out = self.critic_mlp(obs) if self.separate else a_out
        value = self.value_act(self.value(c_out))
        if not self.continuous:
            return self.logits(a_out), value, None
        mu = self.mu_act(self.mu(a_out))
        if self.fixed_sigma:
            sigma = self.sigma_act(self.sigma).expand_as(mu)
        else:
            sigma = self.sigma_act(self.sigma(a_out))
        return mu, sigma, value, None

    def is_rnn(self) -> bool:
        return False


class ActorCriticBuilder(NetworkBuilder):
    """Builder registered as ``actor_critic``."""

    config_class = NetworkConfig

    def build(self, name: str, **kwargs: Any) -> nn.Module:
        space = kwargs["action_space"]
        continuous = isinstance(space, gym.spaces.Box)
        cfg: NetworkConfig = self.params
        if continuous and cfg.space.continuous is None:
            raise ValueError("params.network.space: the env has continuous actions (Box); add `continuous:`")
        if isinstance(space, gym.spaces.Discrete) and cfg.space.discrete is None:
            raise ValueError("params.network.space: the env has Discrete actions; add `discrete:`")
        return ActorCriticNetwork(cfg, tuple(kwargs["input_shape"]), kwargs["actions_num"],
                                  kwargs.get("value_size", 1), continuous)
