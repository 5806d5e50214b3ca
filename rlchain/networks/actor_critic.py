"""The built-in ``actor_critic`` network: trunk (cnn -> mlp/rnn, shared or separate) + heads."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn

from rlchain.config.network import NetworkConfig
from rlchain.networks.base import NetworkBuilder
from rlchain.networks.cnn import ConvEncoder
from rlchain.networks.history import HistoryLayer
from rlchain.networks.layers import activation, initialize, linear
from rlchain.networks.mlp import MLP
from rlchain.networks.rnn import RecurrentLayer, States


class Trunk(nn.Module):
    """Observation -> features: an encoder (the cnn block's, or ``encoder``), then MLP and optional RNN
    in either order.

    ``forward(obs, states, resets, seq_length, bptt_length, extra)`` returns ``(features (B, out_size),
    new states)``; without an RNN the states pass through as an empty tuple. ``encoder``: any module
    (B, *input_shape) -> (B, encoder.out_size) in place of the cnn block. ``extra_size`` > 0: ``extra``
    (B, extra_size) features are concatenated to the recurrent layer's input (to the MLP's without an
    RNN), as rl_games' resnet network feeds the previous reward and action. ``rnn.concat_input``
    feeds the encoder features (conv output, or the flat obs without a ``cnn``) to an RNN after the
    MLP alongside the MLP output; ``rnn.concat_output`` appends those same encoder features to the
    RNN output (after its LayerNorm), in both orders, as rl_games does.
    """

    def __init__(self, cfg: NetworkConfig, input_shape: tuple[int, ...], encoder: nn.Module | None = None,
                 extra_size: int = 0) -> None:
        super().__init__()
        if encoder is None and cfg.cnn is not None:
            encoder = ConvEncoder(cfg.cnn, input_shape)
        self.cnn = encoder
        in_size = self.cnn.out_size if self.cnn is not None else int(np.prod(input_shape))
        mlp_cfg = cfg.mlp
        if cfg.normalization is not None and mlp_cfg.normalization is None:
            mlp_cfg = dataclasses.replace(mlp_cfg, normalization=cfg.normalization)
        rnn = cfg.rnn
        history = getattr(cfg, "history", None)
        if history is not None:  # the window transformer in the recurrent layer's place, after the MLP
            self.before_mlp = self.concat_input = self.concat_output = False
            self.mlp = MLP(in_size, mlp_cfg)
            self.rnn: RecurrentLayer | HistoryLayer | None = HistoryLayer(self.mlp.out_size + extra_size, history)
            self.out_size = self.rnn.out_size
            return
        self.before_mlp = rnn is not None and rnn.before_mlp
        self.concat_input = rnn is not None and rnn.concat_input and not rnn.before_mlp
        self.concat_output = rnn is not None and rnn.concat_output
        self.rnn = None
        if rnn is None:
            self.mlp = MLP(in_size + extra_size, mlp_cfg)
            self.out_size = self.mlp.out_size
            return
        rnn_out = rnn.units + (in_size if self.concat_output else 0)
        if self.before_mlp:
            self.rnn = RecurrentLayer(in_size + extra_size, rnn)
            self.mlp = MLP(rnn_out, mlp_cfg)
            self.out_size = self.mlp.out_size
        else:
            self.mlp = MLP(in_size, mlp_cfg)
            self.rnn = RecurrentLayer(self.mlp.out_size + (in_size if self.concat_input else 0) + extra_size, rnn)
            self.out_size = rnn_out

    @property
    def num_states(self) -> int:
        return self.rnn.num_states if self.rnn is not None else 0

    def initial_state(self, batch: int, device: torch.device) -> States:
        return self.rnn.initial_state(batch, device) if self.rnn is not None else ()

    def forward(self, obs: torch.Tensor, states: States, resets: torch.Tensor | None,
                seq_length: int, bptt_length: int | None = None,
                extra: torch.Tensor | None = None) -> tuple[torch.Tensor, States]:
        x = self.cnn(obs) if self.cnn is not None else obs.flatten(1)
        if self.rnn is None:
            return self.mlp(_cat(x, extra)), states
        if self.before_mlp:
            out, states = self.rnn(_cat(x, extra), states, resets, seq_length, bptt_length)
        else:
            out = self.mlp(x)
            if self.concat_input:
                out = torch.cat([out, x], -1)
            out, states = self.rnn(_cat(out, extra), states, resets, seq_length, bptt_length)
        if self.concat_output:
            out = torch.cat([out, x], -1)
        return (self.mlp(out) if self.before_mlp else out), states


def _cat(x: torch.Tensor, extra: torch.Tensor | None) -> torch.Tensor:
    return x if extra is None else torch.cat([x, extra], -1)


class ActorCriticNetwork(nn.Module):
    """Returns rl_games' tuple: ``(logits, value, states)`` or ``(mu, sigma, value, states)``.

    Shapes: obs (B, *input_shape) -> logits (B, actions_num) | mu, sigma (B, actions_num);
    value (B, value_size). ``input_dict`` may carry ``rnn_states`` (a tuple, actor states then
    critic states when separate), ``dones`` (B,) episode starts and ``seq_length``.

    ``cfg`` is a NetworkConfig or another block with its fields (ResnetNetworkConfig). Subclasses
    give their own trunks through ``make_trunk`` and split composite observations in :meth:`split_obs`.
    """

    def __init__(self, cfg: NetworkConfig, input_shape: tuple[int, ...], actions_num: int,
                 value_size: int, continuous: bool, make_trunk: Callable[[], Trunk] | None = None) -> None:
        super().__init__()
        self.separate = cfg.separate
        critic_mlp = getattr(cfg, "critic_mlp", None)  # separate only (parse_network checks)
        make_critic = (lambda: Trunk(dataclasses.replace(cfg, mlp=critic_mlp), input_shape)) \
            if critic_mlp is not None else None
        make_trunk = make_trunk or (lambda: Trunk(cfg, input_shape))
        self.actor_trunk = make_trunk()
        self.critic_trunk = (make_critic or make_trunk)() if cfg.separate else None
        out = self.actor_trunk.out_size
        init = cfg.mlp.initializer
        # the value head sits on the critic's trunk when it has one of its own
        self.value = linear(self.critic_trunk.out_size if critic_mlp is not None else out, value_size,
                            critic_mlp.initializer if critic_mlp is not None else init)
        self.value_act = activation(cfg.value_activation)
        self.continuous = continuous
        if continuous:
            space = cfg.space.continuous
            # rl_games: every Linear gets the mlp initializer (zero bias), then mu_init on top
            self.mu = linear(out, actions_num, init)
            initialize(self.mu.weight, space.mu_init)
            self.mu_act = activation(space.mu_activation)
            self.sigma_act = activation(space.sigma_activation)
            self.fixed_sigma = space.fixed_sigma
            # rl_games 2.0: read by the model's distribution (rlchain.models.distributions.DiagGaussian)
            self.sigma_parametrization = "linear" if space.sigma_parametrization == "scalar" \
                else space.sigma_parametrization
            self.min_sigma = float(space.min_sigma)
            self.logstd_bounds = tuple(space.logstd_bounds) if space.logstd_bounds is not None else None
            if self.fixed_sigma:
                self.sigma = nn.Parameter(torch.zeros(actions_num))
                initialize(self.sigma.data.view(1, -1), space.sigma_init)
            else:
                self.sigma = linear(out, actions_num, init)
                initialize(self.sigma.weight, space.sigma_init)
        else:
            self.logits = linear(out, actions_num, init)

    def split_obs(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
        """(trunk input, extra features for the trunk or None); subclasses with composite
        observations split them here (see networks/resnet_actor_critic.py)."""
        return obs, None

    def forward(self, input_dict: dict[str, Any]) -> tuple:
        obs, extra = self.split_obs(input_dict["obs"])
        states = tuple(input_dict.get("rnn_states") or ())
        resets = input_dict.get("dones")
        seq_length = int(input_dict.get("seq_length", 1) or 1)
        bptt = input_dict.get("bptt_len")
        n_actor = self.actor_trunk.num_states
        a_out, a_states = self.actor_trunk(obs, states[:n_actor], resets, seq_length, bptt, extra)
        if self.critic_trunk is not None:
            c_out, c_states = self.critic_trunk(obs, states[n_actor:], resets, seq_length, bptt, extra)
        else:
            c_out, c_states = a_out, ()
        new_states = (*a_states, *c_states) if self.is_rnn() else None
        value = self.value_act(self.value(c_out))
        if not self.continuous:
            return self.logits(a_out), value, new_states
        mu = self.mu_act(self.mu(a_out))
        if self.fixed_sigma:
            sigma = self.sigma_act(self.sigma).expand_as(mu)
        else:
            sigma = self.sigma_act(self.sigma(a_out))
        return mu, sigma, value, new_states

    def is_rnn(self) -> bool:
        return self.actor_trunk.rnn is not None

    def get_default_rnn_state(self, batch: int = 1, device: torch.device | None = None) -> States:
        """Zero recurrent states for ``batch`` envs (empty without an RNN); rl_games' name."""
        device = device or self.value.weight.device
        states = self.actor_trunk.initial_state(batch, device)
        if self.critic_trunk is not None:
            states = (*states, *self.critic_trunk.initial_state(batch, device))
        return states


def is_continuous(cfg: NetworkConfig, space: gym.Space) -> bool:
    """Whether ``space`` takes the continuous head; a one-line error when ``cfg.space`` lacks the
    head the env's actions need."""
    continuous = isinstance(space, gym.spaces.Box)
    if continuous and cfg.space.continuous is None:
        raise ValueError("params.network.space: the env has continuous actions (Box); add `continuous:`")
    if isinstance(space, gym.spaces.Discrete) and cfg.space.discrete is None:
        raise ValueError("params.network.space: the env has Discrete actions; add `discrete:`")
    multi = (gym.spaces.MultiDiscrete, gym.spaces.MultiBinary, gym.spaces.Tuple)
    if isinstance(space, multi) and cfg.space.multi_discrete is None:
        raise ValueError(f"params.network.space: the env has {space} actions; add `multi_discrete:`")
    return continuous


class ActorCriticBuilder(NetworkBuilder):
    """Builder registered as ``actor_critic``."""

    config_class = NetworkConfig

    def build(self, name: str, **kwargs: Any) -> nn.Module:
        cfg: NetworkConfig = self.params
        continuous = is_continuous(cfg, kwargs["action_space"])
        return ActorCriticNetwork(cfg, tuple(kwargs["input_shape"]), kwargs["actions_num"],
                                  kwargs.get("value_size", 1), continuous)
