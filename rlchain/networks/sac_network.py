"""Networks for the off-policy algorithms: ``soft_actor_critic`` (actor + twin critics) and ``dqn``.

``soft_actor_critic`` on Box actions: a Gaussian actor (mu, log_std) and twin critics of (obs, action); on
Discrete(n) actions: a categorical actor (n logits) and twin critics of obs with one Q-value per action (RLlib's
and Christodoulou's discrete SAC). Both read the same ``mlp`` block.

Both follow the builder contract of :mod:`rlchain.networks.base` and read rl_games' network block
keys (``mlp.units / activation / initializer``, ``log_std_bounds``; ``dueling`` and ``head`` for DQN).

With Dict observations kept per key (``network.name: multi_input``, :func:`multi_input_off_policy`) the
actor, the critic and the Q-network each read the observations through an ``encoder`` of their own (an
encoder per key, :class:`~rlchain.networks.multi_input.MultiInputEncoder`); the twin critics share theirs.
Without one they read a flat vector, as always.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn

from rlchain.config.network import MlpConfig
from rlchain.config.off_policy import DQNNetworkConfig, SACNetworkConfig
from rlchain.networks.layers import linear
from rlchain.networks.mlp import MLP


class SACActor(nn.Module):
    """obs (B, obs_dim) -> (mu, log_std), each (B, A); log_std squashed into ``log_std_bounds``.
    ``encoder`` (an ``out_size`` module, e.g. per-key encoders of an ObsDict) runs before the MLP when given.
    ``trunk``: the hidden layers and the (mu, log_std) output layer in one Sequential, rl_games' actor."""

    def __init__(self, obs_dim: int, actions_num: int, mlp: MlpConfig, log_std_bounds: list[float],
                 mean_clip: float | None = None, encoder: nn.Module | None = None) -> None:
        super().__init__()
        self.encoder = encoder
        self.trunk = MLP(obs_dim if encoder is None else encoder.out_size, mlp, output=2 * actions_num)
        self.log_std_bounds = (float(log_std_bounds[0]), float(log_std_bounds[1]))
        self.mean_clip = None if mean_clip is None else float(mean_clip)

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        if self.encoder is not None:
            obs = self.encoder(obs)
        mu, log_std = self.trunk(obs).chunk(2, dim=-1)
        if self.mean_clip is not None:  # SB3's Hardtanh on the gSDE actor's mean
            mu = mu.clamp(-self.mean_clip, self.mean_clip)
        low, high = self.log_std_bounds
        log_std = low + 0.5 * (high - low) * (torch.tanh(log_std) + 1.0)  # rl_games' soft bound
        return mu, log_std


class TwinQCritic(nn.Module):
    """(obs (B, obs_dim), actions (B, A)) -> (q1, q2), each (B,); ``encoder`` (shared by both Qs) first when given.
    ``Q1`` / ``Q2``: hidden layers and output in one Sequential each, rl_games' names."""

    def __init__(self, obs_dim: int, actions_num: int, mlp: MlpConfig, encoder: nn.Module | None = None) -> None:
        super().__init__()
        self.encoder = encoder
        obs_dim = obs_dim if encoder is None else encoder.out_size
        self.Q1 = MLP(obs_dim + actions_num, mlp, output=1)
        self.Q2 = MLP(obs_dim + actions_num, mlp, output=1)

    def forward(self, obs: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.cat([obs if self.encoder is None else self.encoder(obs), actions], dim=-1)
        return self.Q1(x).squeeze(-1), self.Q2(x).squeeze(-1)


class CategoricalActor(nn.Module):
    """obs (B, obs_dim) -> logits (B, n); ``encoder`` first when given. ``trunk``: hidden layers and output."""

    def __init__(self, obs_dim: int, actions_num: int, mlp: MlpConfig, encoder: nn.Module | None = None) -> None:
        super().__init__()
        self.encoder = encoder
        self.trunk = MLP(obs_dim if encoder is None else encoder.out_size, mlp, output=actions_num)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.trunk(obs if self.encoder is None else self.encoder(obs))


class TwinQPerAction(nn.Module):
    """obs (B, obs_dim) -> (q1, q2), each (B, n): one Q-value per discrete action; ``encoder`` (shared by both Qs)
    first when given. ``Q1`` / ``Q2``: hidden layers and output in one Sequential each."""

    def __init__(self, obs_dim: int, actions_num: int, mlp: MlpConfig, encoder: nn.Module | None = None) -> None:
        super().__init__()
        self.encoder = encoder
        obs_dim = obs_dim if encoder is None else encoder.out_size
        self.Q1 = MLP(obs_dim, mlp, output=actions_num)
        self.Q2 = MLP(obs_dim, mlp, output=actions_num)

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = obs if self.encoder is None else self.encoder(obs)
        return self.Q1(x), self.Q2(x)


class SACNetwork(nn.Module):
    """``actor`` and ``critic`` (twin Q) submodules; ``forward`` is rl_games' ``(mu, log_std, None, None)``
    (``discrete``: ``(logits, None, None, None)``). ``make_encoder`` (Dict observations kept per key): the actor
    and the critic each get one it builds."""

    def __init__(self, cfg: SACNetworkConfig, input_shape: tuple[int, ...], actions_num: int,
                 make_encoder: Callable[[], nn.Module] | None = None, discrete: bool = False) -> None:
        super().__init__()
        obs_dim = int(np.prod(input_shape))
        mlp = cfg.mlp
        if cfg.normalization is not None and mlp.normalization is None:  # rl_games 2.0: actor and critics
            mlp = dataclasses.replace(mlp, normalization=cfg.normalization)
        per_key = make_encoder is not None
        if discrete:
            self.actor = CategoricalActor(obs_dim, actions_num, mlp, make_encoder() if per_key else None)
            self.critic = TwinQPerAction(obs_dim, actions_num, mlp, make_encoder() if per_key else None)
        else:
            self.actor = SACActor(obs_dim, actions_num, mlp, cfg.log_std_bounds, cfg.mean_clip,
                                  make_encoder() if per_key else None)
            self.critic = TwinQCritic(obs_dim, actions_num, mlp, make_encoder() if per_key else None)
        self.per_key = per_key

    def forward(self, input_dict: dict[str, Any]) -> tuple:
        obs = input_dict["obs"]
        out = self.actor(obs if self.per_key else obs.flatten(1))
        return (*out, None, None) if isinstance(out, tuple) else (out, None, None, None)

    def is_rnn(self) -> bool:
        return False


def sac_network(cfg: SACNetworkConfig, **kwargs: Any) -> nn.Module:
    """The network registered as ``soft_actor_critic``: Box or Discrete actions."""
    space = kwargs["action_space"]
    if not isinstance(space, (gym.spaces.Box, gym.spaces.Discrete)):
        raise ValueError(f"params.network: soft_actor_critic needs Box or Discrete actions, the env has {space}")
    discrete = isinstance(space, gym.spaces.Discrete)
    if discrete and cfg.mean_clip is not None:
        raise ValueError("params.network.mean_clip: clips a Gaussian policy's mean; Discrete actions have a "
                         "categorical policy (remove it)")
    return SACNetwork(cfg, tuple(kwargs["input_shape"]), kwargs["actions_num"], discrete=discrete)


sac_network.config_class = SACNetworkConfig


class QNetwork(nn.Module):
    """obs (B, *input_shape) -> Q-values (B, actions_num); dueling: V + A - mean(A). ``encoder`` (Dict
    observations kept per key) reads the observations before the MLP when given."""

    def __init__(self, cfg: DQNNetworkConfig, input_shape: tuple[int, ...], actions_num: int,
                 encoder: nn.Module | None = None) -> None:
        super().__init__()
        self.encoder = encoder
        self.trunk = MLP(int(np.prod(input_shape)) if encoder is None else encoder.out_size, cfg.mlp)
        size = self.trunk.out_size
        self.dueling = cfg.dueling
        self.advantage = _stream(size, actions_num, cfg)
        self.state_value = _stream(size, 1, cfg) if cfg.dueling else None

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        h = self.trunk(obs.flatten(1) if self.encoder is None else self.encoder(obs))
        adv = self.advantage(h)
        if self.state_value is None:
            return adv
        return self.state_value(h) + adv - adv.mean(-1, keepdim=True)

    def is_rnn(self) -> bool:
        return False


def _stream(size: int, out: int, cfg: DQNNetworkConfig) -> nn.Module:
    """One output stream of the Q-network: ``cfg.head``'s hidden layers (when given) then a linear layer."""
    if cfg.head is None or not cfg.head.units:
        return linear(size, out, cfg.mlp.initializer)
    hidden = MLP(size, cfg.head)
    return nn.Sequential(hidden, linear(hidden.out_size, out, cfg.head.initializer))


def q_network(cfg: DQNNetworkConfig, **kwargs: Any) -> nn.Module:
    """The network registered as ``dqn``."""
    if not isinstance(kwargs["action_space"], gym.spaces.Discrete):
        raise ValueError(f"params.network: dqn needs Discrete actions, the env has {kwargs['action_space']}")
    return QNetwork(cfg, tuple(kwargs["input_shape"]), kwargs["actions_num"])


q_network.config_class = DQNNetworkConfig


OFF_POLICY_MODELS = ("soft_actor_critic", "dqn")
"""Model presets whose network ``multi_input`` builds with :func:`multi_input_off_policy`."""


def multi_input_off_policy(cfg: Any, model_name: str, make_encoder: Callable[[], nn.Module],
                           actions_num: int, discrete: bool = False) -> nn.Module:
    """The ``multi_input`` network of an off-policy model: ``soft_actor_critic``'s actor and twin critic (an
    encoder each) or ``dqn``'s Q-network, their hidden layers from ``cfg.mlp``; ``log_std_bounds`` comes from
    the config (or its default [-5, 2]) and DQN's head is dueling."""
    if cfg.rnn is not None or cfg.history is not None:
        raise ValueError(f"params.network: multi_input with model {model_name} takes no rnn or history "
                         f"(off-policy networks are feed-forward)")
    if model_name == "soft_actor_critic":
        if cfg.dueling is not None:
            raise ValueError("params.network.dueling: a DQN head; model soft_actor_critic has none (remove it)")
        sac = SACNetworkConfig(mlp=cfg.mlp, normalization=cfg.normalization)
        return SACNetwork(sac, (), actions_num, make_encoder, discrete)
    dueling = True if cfg.dueling is None else cfg.dueling
    return QNetwork(DQNNetworkConfig(mlp=cfg.mlp, dueling=dueling), (), actions_num, make_encoder())
