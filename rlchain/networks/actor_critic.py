"""The built-in ``actor_critic`` network, laid out as rl_games' ``A2CBuilder.Network``.

Its modules carry rl_games' names and registration order, so its state dict is rl_games' own (under the model's
``a2c_network.``) and its parameters sit in the order rl_games' optimizer holds them: the fixed ``sigma`` vector,
``actor_cnn`` / ``critic_cnn`` (``cnn`` for ``resnet_actor_critic``), ``actor_mlp`` / ``critic_mlp`` (one
Sequential each; ``mlp`` for resnet), the recurrent layer ``rnn`` (``a_rnn`` / ``c_rnn`` when separate) and its
output LayerNorm ``layer_norm`` (``a_layer_norm`` / ``c_layer_norm``), then ``value``, ``logits`` (one Linear per
action dimension for multi-discrete actions), ``mu`` and ``sigma``. rlchain's own options (the norm before the
activation, dropout, D2RL, ``critic_mlp``, the ``history`` window, multi-input encoders) are options of the same
modules; rl_games cannot compute those networks, and their files do not load there.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn

from rlchain.config.network import NetworkConfig
from rlchain.models.distributions import multi_discrete_dims
from rlchain.networks.base import NetworkBuilder
from rlchain.networks.cnn import ConvEncoder
from rlchain.networks.history import HistoryLayer
from rlchain.networks.layers import activation, initialize, linear
from rlchain.networks.mlp import MLP
from rlchain.networks.rnn import RecurrentLayer, States, flat_sequences

RL_GAMES_ORDER = ("cnn", "actor_cnn", "critic_cnn", "actor_mlp", "critic_mlp", "rnn", "a_rnn", "c_rnn", "layer_norm",
                  "a_layer_norm", "c_layer_norm", "mlp", "actor_head", "critic_head", "value", "logits", "mu", "sigma")
"""The order rl_games' actor-critic networks register their modules in (its optimizer's parameter order); the
per-stream ``actor_head`` / ``critic_head`` (``network.head``) are rlchain's, between the trunks and the outputs."""


@dataclasses.dataclass(frozen=True)
class TrunkLayout:
    """How one trunk's modules connect: the module names (None: absent) and the rnn block's wiring.

    Observation -> features: the encoder (``cnn``), then MLP and optional recurrent layer in either order.
    ``extra`` features (rl_games' resnet: the previous reward and action) join the recurrent layer's input (the
    MLP's without one). ``concat_input`` feeds the encoder features to an RNN after the MLP alongside the MLP
    output; ``concat_output`` appends them to the RNN output (after its LayerNorm), as rl_games does."""

    cnn: str | None
    mlp: str
    rnn: str | None
    norm: str | None
    before_mlp: bool
    concat_input: bool
    concat_output: bool
    out_size: int
    window: bool = False  # the recurrent slot holds the history window (flat rows in, not rl_games' call)


def build_trunk(cfg: NetworkConfig, input_shape: tuple[int, ...], encoder: nn.Module | None, extra_size: int,
                names: tuple[str, str, str, str]) -> tuple[dict[str, nn.Module], TrunkLayout]:
    """One trunk's modules by name (``names``: cnn, mlp, rnn, layer norm) and its layout. ``encoder``: any
    module (B, *input_shape) -> (B, encoder.out_size) in place of the cnn block's."""
    if encoder is None and cfg.cnn is not None:
        encoder = ConvEncoder(cfg.cnn, input_shape)
    in_size = encoder.out_size if encoder is not None else int(np.prod(input_shape))
    mlp_cfg = cfg.mlp
    if cfg.normalization is not None and mlp_cfg.normalization is None:
        mlp_cfg = dataclasses.replace(mlp_cfg, normalization=cfg.normalization)
    cnn_name, mlp_name, rnn_name, norm_name = names
    modules: dict[str, nn.Module] = {cnn_name: encoder} if encoder is not None else {}
    rnn, history = cfg.rnn, getattr(cfg, "history", None)
    before = rnn is not None and rnn.before_mlp and history is None
    concat_input = rnn is not None and rnn.concat_input and not rnn.before_mlp and history is None
    concat_output = rnn is not None and rnn.concat_output and history is None
    if history is not None:  # the window transformer in the recurrent layer's place, after the MLP
        mlp = modules[mlp_name] = MLP(in_size, mlp_cfg)
        layer = modules[rnn_name] = HistoryLayer(mlp.out_size + extra_size, history)
        out_size = layer.out_size
    elif rnn is None:
        mlp = modules[mlp_name] = MLP(in_size + extra_size, mlp_cfg)
        out_size = mlp.out_size
    else:
        rnn_out = rnn.units + (in_size if concat_output else 0)
        if before:
            modules[rnn_name] = RecurrentLayer(in_size + extra_size, rnn)
            mlp = modules[mlp_name] = MLP(rnn_out, mlp_cfg)
            out_size = mlp.out_size
        else:
            mlp = modules[mlp_name] = MLP(in_size, mlp_cfg)
            modules[rnn_name] = RecurrentLayer(mlp.out_size + (in_size if concat_input else 0) + extra_size, rnn)
            out_size = rnn_out
        if rnn.layer_norm:
            modules[norm_name] = nn.LayerNorm(rnn.units)
    has_rnn = rnn is not None or history is not None
    return modules, TrunkLayout(cnn_name if encoder is not None else None, mlp_name, rnn_name if has_rnn else None,
                                norm_name if norm_name in modules else None, before, concat_input, concat_output,
                                out_size, history is not None)


def _cat(x: torch.Tensor, extra: torch.Tensor | None) -> torch.Tensor:
    return x if extra is None else torch.cat([x, extra], -1)


class ActorCriticNetwork(nn.Module):
    """Returns rl_games' tuple: ``(logits, value, states)`` or ``(mu, sigma, value, states)``; built with
    ``central_value`` (a critic of its own), ``(value, states)``.

    Shapes: obs (B, *input_shape) -> logits (B, actions_num) | mu, sigma (B, actions_num);
    value (B, value_size). ``input_dict`` may carry ``rnn_states`` (a tuple, actor states then
    critic states when separate), ``dones`` (B,) episode starts and ``seq_length``.

    ``cfg`` is a NetworkConfig or another block with its fields (ResnetNetworkConfig). ``make_encoder``
    builds a trunk's encoder in place of the cnn block's (one call per trunk); ``extra_size`` features come
    from :meth:`split_obs`. ``logits_sizes``: the per-dimension sizes of a multi-discrete head, whose logits come
    out as rl_games' list, one (B, n_k) tensor per dimension. ``num_seqs``: the batch of
    :meth:`get_default_rnn_state` called without one (rl_games' call).

    rl_games' ``A2CBuilder.Network`` (rlchain/rl_games/algos_torch/network_builder.py) is this class built from a
    plain network block; the trunks' layouts are ``actor_layout`` and ``critic_layout`` (None without a separate
    critic).
    """

    CNN, MLP_NAME = ("actor_cnn", "critic_cnn"), ("actor_mlp", "critic_mlp")

    def __init__(self, cfg: NetworkConfig, input_shape: tuple[int, ...], actions_num: int,
                 value_size: int, continuous: bool, make_encoder: Callable[[], nn.Module | None] | None = None,
                 extra_size: int = 0, central_value: bool = False, logits_sizes: list[int] | None = None,
                 num_seqs: int = 1) -> None:
        super().__init__()
        self.num_seqs = num_seqs
        self.separate = cfg.separate
        self.central_value = central_value
        make_encoder = make_encoder or (lambda: None)
        critic_mlp = getattr(cfg, "critic_mlp", None)  # separate only (parse_network checks)
        rnn_names = ("a_rnn", "c_rnn") if cfg.separate else ("rnn", "")
        norm_names = ("a_layer_norm", "c_layer_norm") if cfg.separate else ("layer_norm", "")
        # built in the trunks' order (the weights' random draws), registered below in rl_games' order
        modules, self.actor_layout = build_trunk(cfg, input_shape, make_encoder(), extra_size,
                                          (self.CNN[0], self.MLP_NAME[0], rnn_names[0], norm_names[0]))
        self.critic_layout: TrunkLayout | None = None
        if cfg.separate:
            critic_cfg = dataclasses.replace(cfg, mlp=critic_mlp) if critic_mlp is not None else cfg
            critic_modules, self.critic_layout = build_trunk(critic_cfg, input_shape, make_encoder(), extra_size,
                                                      (self.CNN[1], self.MLP_NAME[1], rnn_names[1], norm_names[1]))
            modules.update(critic_modules)
        init = cfg.mlp.initializer
        out = self.actor_layout.out_size
        critic_out = (self.critic_layout or self.actor_layout).out_size
        head = getattr(cfg, "head", None)
        self.has_heads = head is not None
        if head is not None:  # each output stream's own hidden layers (RLlib's pi and vf heads)
            if not central_value:
                modules["actor_head"] = MLP(out, head)
                out = modules["actor_head"].out_size
            modules["critic_head"] = MLP(critic_out, head)
            critic_out = modules["critic_head"].out_size
        # the value head sits on the critic's trunk when it has one of its own
        modules["value"] = linear(critic_out, value_size, critic_mlp.initializer if critic_mlp is not None else init)
        self.value_act = activation(cfg.value_activation)
        self.continuous = continuous
        if central_value:
            pass
        elif continuous:
            space = cfg.space.continuous
            # rl_games: every Linear gets the mlp initializer (zero bias), then mu_init on top
            modules["mu"] = linear(out, actions_num, init)
            initialize(modules["mu"].weight, space.mu_init)
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
                modules["sigma"] = linear(out, actions_num, init)
                initialize(modules["sigma"].weight, space.sigma_init)
        else:
            modules["logits"] = linear(out, actions_num, init)
            if logits_sizes is not None:
                modules["logits"] = split_linear(modules["logits"], logits_sizes)
        for name in RL_GAMES_ORDER:
            if name in modules:
                setattr(self, name, modules[name])

    def split_obs(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
        """(trunk input, extra features for the trunk or None); subclasses with composite
        observations split them here (see networks/resnet_actor_critic.py)."""
        return obs, None

    def _trunk(self, layout: TrunkLayout, obs: torch.Tensor, states: States, resets: torch.Tensor | None,
               seq_length: int, bptt: int | None, extra: torch.Tensor | None) -> tuple[torch.Tensor, States]:
        """Features (B, out_size) of one trunk and its new recurrent states (the input's without an RNN)."""
        if layout.cnn is not None:
            x = getattr(self, layout.cnn)(obs)
        else:  # flattened (B, features); a (B, n) batch already is (flatten(1) would return it as it is)
            x = obs if type(obs) is torch.Tensor and obs.dim() == 2 else obs.flatten(1)
        mlp = getattr(self, layout.mlp)
        if layout.rnn is None:
            return mlp(_cat(x, extra)), states
        rnn = getattr(self, layout.rnn)
        run = rnn if layout.window else functools.partial(flat_sequences, rnn)
        if layout.before_mlp:
            out, states = run(_cat(x, extra), states, resets, seq_length, bptt)
        else:
            out = mlp(x)
            if layout.concat_input:
                out = torch.cat([out, x], -1)
            out, states = run(_cat(out, extra), states, resets, seq_length, bptt)
        if layout.norm is not None:
            out = getattr(self, layout.norm)(out)
        if layout.concat_output:
            out = torch.cat([out, x], -1)
        return (mlp(out) if layout.before_mlp else out), states

    def forward(self, input_dict: dict[str, Any]) -> tuple:
        obs, extra = self.split_obs(input_dict["obs"])
        states = tuple(input_dict.get("rnn_states") or ())
        resets = input_dict.get("dones")
        seq_length = int(input_dict.get("seq_length", 1) or 1)
        bptt = input_dict.get("bptt_len")
        n_actor = self._num_states(self.actor_layout)
        a_out, a_states = self._trunk(self.actor_layout, obs, states[:n_actor], resets, seq_length, bptt, extra)
        if self.critic_layout is not None:
            c_out, c_states = self._trunk(self.critic_layout, obs, states[n_actor:], resets, seq_length, bptt,
                                          extra)
        else:
            c_out, c_states = a_out, ()
        new_states = (*a_states, *c_states) if self.is_rnn() else None
        if self.has_heads:
            c_out = self.critic_head(c_out)
            a_out = a_out if self.central_value else self.actor_head(a_out)
        value = self.value_act(self.value(c_out))
        if self.central_value:
            return value, new_states
        if not self.continuous:
            logits = self.logits
            out = [head(a_out) for head in logits] if isinstance(logits, nn.ModuleList) else logits(a_out)
            return out, value, new_states
        mu = self.mu_act(self.mu(a_out))
        if self.fixed_sigma:
            sigma = self.sigma_act(self.sigma).expand_as(mu)
        else:
            sigma = self.sigma_act(self.sigma(a_out))
        return mu, sigma, value, new_states

    def _num_states(self, layout: TrunkLayout | None) -> int:
        return getattr(self, layout.rnn).num_states if layout is not None and layout.rnn is not None else 0

    def is_rnn(self) -> bool:
        return self.actor_layout.rnn is not None

    def is_separate_critic(self) -> bool:
        return self.separate

    def get_default_rnn_state(self, batch: int | None = None, device: torch.device | None = None) -> States | None:
        """Zero recurrent states for ``batch`` envs (``num_seqs`` when None), each (layers, batch, units), the
        actor's then the critic's: (h, c) per trunk for an LSTM, h for a GRU; None without an RNN (rl_games')."""
        if not self.is_rnn():
            return None
        device = device or self.value.weight.device
        batch = self.num_seqs if batch is None else batch
        return tuple(state for layout in (self.actor_layout, self.critic_layout)
                     if layout is not None and layout.rnn is not None
                     for state in getattr(self, layout.rnn).initial_state(batch, device))


def split_linear(joined: nn.Linear, sizes: list[int]) -> nn.ModuleList:
    """rl_games' multi-discrete head: one Linear per action dimension (``logits.<i>``), holding the rows of
    ``joined`` (built first, so the weights are those the one joined head drew)."""
    heads = nn.ModuleList()
    for weight, bias in zip(joined.weight.detach().split(sizes), joined.bias.detach().split(sizes)):
        head = nn.utils.skip_init(type(joined), joined.in_features, weight.shape[0])
        with torch.no_grad():
            head.weight.copy_(weight)
            head.bias.copy_(bias)
        heads.append(head)
    return heads


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


def logits_sizes(space: gym.Space) -> list[int] | None:
    """The per-dimension sizes of a MultiDiscrete, MultiBinary or Tuple-of-Discrete action space, else None."""
    dims = multi_discrete_dims(space)
    return None if dims is None else dims[0]


class ActorCriticBuilder(NetworkBuilder):
    """Builder registered as ``actor_critic``."""

    config_class = NetworkConfig

    def build(self, name: str, **kwargs: Any) -> nn.Module:
        cfg: NetworkConfig = self.params
        space = kwargs["action_space"]
        return ActorCriticNetwork(cfg, tuple(kwargs["input_shape"]), kwargs["actions_num"],
                                  kwargs.get("value_size", 1), is_continuous(cfg, space),
                                  logits_sizes=logits_sizes(space), num_seqs=kwargs.get("num_seqs", 1))
