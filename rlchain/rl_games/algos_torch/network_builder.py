"""rl_games' ``network_builder``: ``NetworkBuilder`` (with ``BaseNetwork``) and ``A2CBuilder``, whose inner
``A2CBuilder.Network`` is the actor-critic network rl_games builds from a ``params.network`` block.

User code subclasses them the rl_games way: ``class MyBuilder(A2CBuilder)`` with ``class Network(
A2CBuilder.Network)`` calling ``super().__init__(params, **kwargs)`` and then reading or extending what was
built (``actor_mlp``, ``critic_mlp``, ``actor_cnn``, ``critic_cnn``, ``rnn`` / ``a_rnn`` / ``c_rnn``, ``units``,
``separate``, ``value``, ``value_act``, ``logits``, ``mu``, ``mu_act``, ``sigma``, ``sigma_act``, ``space_config``).
``forward(obs_dict)`` reads ``obs``, ``rnn_states``, ``dones``, ``seq_length``, ``bptt_len`` (rlchain also passes
``is_train`` and, in training passes, ``prev_actions``) and returns rl_games' tuple: ``(mu, sigma, value,
states)`` continuous, ``(logits, value, states)`` discrete (a list of logits per dimension for
multi-discrete), ``(value, states)`` for a ``central_value`` block. Register one with
``rl_games.algos_torch.model_builder.register_network(name, MyBuilder)``.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn as nn

from rlchain.networks import NetworkBuilder as _RlchainBuilder
from rlchain.networks.layers import Linear
from rlchain.rl_games.algos_torch.base_network import BaseNetwork
from rlchain.rl_games.algos_torch.sac_helper import SquashedNormal
from rlchain.rl_games.algos_torch.torch_ext import shape_whc_to_cwh


class NetworkBuilder(_RlchainBuilder):
    """A builder: ``load(params)`` keeps the network block, ``build(name, **kwargs)`` returns the module."""

    BaseNetwork = BaseNetwork

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)


class A2CBuilder(NetworkBuilder):
    """rl_games' ``actor_critic`` network builder."""

    def __init__(self, **kwargs: Any) -> None:
        NetworkBuilder.__init__(self)

    def load(self, params: Any) -> None:
        self.params = params

    def build(self, name: str, **kwargs: Any) -> nn.Module:
        return A2CBuilder.Network(self.params, **kwargs)

    class Network(BaseNetwork):
        """Trunk (cnn, then mlp and rnn in the block's order; a second one for the critic when ``separate``) and heads.

        Build kwargs: ``actions_num`` (a list of sizes for multi-discrete), ``input_shape``, ``value_size``,
        ``num_seqs`` (the batch of ``get_default_rnn_state``); others are ignored.
        """

        def __init__(self, params: Any, **kwargs: Any) -> None:
            actions_num = kwargs.pop("actions_num")
            input_shape = tuple(kwargs.pop("input_shape"))
            self.value_size = kwargs.pop("value_size", 1)
            self.num_seqs = kwargs.pop("num_seqs", 1)
            BaseNetwork.__init__(self)
            self.load(params)
            self.actor_cnn: nn.Module = nn.Sequential()
            self.critic_cnn: nn.Module = nn.Sequential()
            self.actor_mlp: nn.Module = nn.Sequential()
            self.critic_mlp: nn.Module = nn.Sequential()
            if self.has_cnn:
                if self.permute_input:
                    input_shape = shape_whc_to_cwh(input_shape)
                cnn_args = {"ctype": self.cnn["type"], "input_shape": input_shape, "convs": self.cnn["convs"],
                            "activation": self.cnn["activation"], "norm_func_name": self.normalization}
                self.actor_cnn = self._build_conv(**cnn_args)
                if self.separate:
                    self.critic_cnn = self._build_conv(**cnn_args)
            cnn_out = self._calc_input_size(input_shape, self.actor_cnn)
            mlp_in = cnn_out
            out_size = self.units[-1] if len(self.units) else cnn_out
            if self.has_rnn:
                if self.is_rnn_before_mlp:
                    rnn_in = cnn_out
                    mlp_in = self.rnn_units + (cnn_out if self.rnn_concat_output else 0)
                    if not len(self.units):
                        out_size = mlp_in
                else:
                    rnn_in = out_size + (cnn_out if self.rnn_concat_input else 0)
                    out_size = self.rnn_units + (cnn_out if self.rnn_concat_output else 0)
                if self.separate:
                    self.a_rnn = self._build_rnn(self.rnn_name, rnn_in, self.rnn_units, self.rnn_layers)
                    self.c_rnn = self._build_rnn(self.rnn_name, rnn_in, self.rnn_units, self.rnn_layers)
                    if self.rnn_ln:
                        self.a_layer_norm = nn.LayerNorm(self.rnn_units)
                        self.c_layer_norm = nn.LayerNorm(self.rnn_units)
                else:
                    self.rnn = self._build_rnn(self.rnn_name, rnn_in, self.rnn_units, self.rnn_layers)
                    if self.rnn_ln:
                        self.layer_norm = nn.LayerNorm(self.rnn_units)
            # rlchain's Linear: nn.Linear's parameters and state dict, a faster weight gradient on a CPU
            mlp_args = {"input_size": mlp_in, "units": self.units, "activation": self.activation,
                        "norm_func_name": self.normalization, "dense_func": Linear, "d2rl": self.is_d2rl,
                        "norm_only_first_layer": self.norm_only_first_layer}
            self.actor_mlp = self._build_mlp(**mlp_args)
            if self.separate:
                self.critic_mlp = self._build_mlp(**mlp_args)
            self.value = self._build_value_layer(out_size, self.value_size)
            self.value_act = self.activations_factory.create(self.value_activation)
            if self.is_discrete:
                self.logits = nn.Linear(out_size, actions_num)
            if self.is_multi_discrete:  # actions_num: one size per dimension
                self.logits = nn.ModuleList([nn.Linear(out_size, n) for n in actions_num])
            if self.is_continuous:
                self._build_continuous_head(out_size, actions_num)
            self._init_weights()

        def _build_continuous_head(self, out_size: int, actions_num: int) -> None:
            space = self.space_config
            self.mu = nn.Linear(out_size, actions_num)
            self.mu_act = self.activations_factory.create(space["mu_activation"])
            self.sigma_act = self.activations_factory.create(space["sigma_activation"])
            # rl_games 2.0's std options, read by rlchain's Gaussian (min_sigma floor, logstd clamp, parametrization)
            self.min_sigma = float(space.get("min_sigma", 0.0))
            self.logstd_bounds = space.get("logstd_bounds", None)
            parametrization = space.get("sigma_parametrization", "exp")
            self.sigma_parametrization = "linear" if parametrization == "scalar" else parametrization
            if self.fixed_sigma:
                self.sigma = nn.Parameter(torch.zeros(actions_num, dtype=torch.float32))
            else:
                self.sigma = nn.Linear(out_size, actions_num)

        def _init_weights(self) -> None:
            """The mlp initializer on every Linear and the cnn one on every conv (zero biases), then the heads'."""
            mlp_init = self.init_factory.create(**self.initializer)
            cnn_init = self.init_factory.create(**self.cnn["initializer"]) if self.has_cnn else None
            for module in self.modules():
                if isinstance(module, (nn.Conv1d, nn.Conv2d)) and cnn_init is not None:
                    cnn_init(module.weight)
                elif isinstance(module, nn.Linear):
                    mlp_init(module.weight)
                else:
                    continue
                if module.bias is not None:
                    nn.init.zeros_(module.bias)
            if not self.is_continuous:
                return
            self.init_factory.create(**self.space_config["mu_init"])(self.mu.weight)
            sigma_init = self.space_config["sigma_init"]
            if self.fixed_sigma:
                self.init_factory.create(**sigma_init)(self.sigma.data)
            elif sigma_init.get("name") == "const_initializer":  # a constant initial std, whatever the input
                nn.init.zeros_(self.sigma.weight)
                nn.init.constant_(self.sigma.bias, sigma_init.get("val", 0.0))
            else:
                self.init_factory.create(**sigma_init)(self.sigma.weight)

        def _trunk(self, obs: torch.Tensor, cnn: nn.Module, mlp: nn.Module, rnn: nn.Module | None,
                   norm: nn.Module | None, states: Any, obs_dict: dict) -> tuple[torch.Tensor, Any]:
            """Features (B, out_size) of one trunk and its new recurrent states (a tuple; the input's without rnn)."""
            out = cnn(obs).flatten(1) if self.has_cnn else obs.flatten(1)
            if rnn is None:
                return mlp(out), states
            cnn_out = out
            if not self.is_rnn_before_mlp:
                out = mlp(out)
                if self.rnn_concat_input:
                    out = torch.cat([out, cnn_out], dim=1)
            seq_length = int(obs_dict.get("seq_length", 1) or 1)
            num_seqs = out.shape[0] // seq_length
            seq = out.reshape(num_seqs, seq_length, -1).transpose(0, 1)  # (T, N, F)
            dones = obs_dict.get("dones", None)
            if dones is not None:
                dones = dones.reshape(num_seqs, seq_length, -1).transpose(0, 1)
            if isinstance(states, (tuple, list)) and len(states) == 1:
                states = states[0]
            seq, states = rnn(seq, states, dones, obs_dict.get("bptt_len", 0) or 0)
            out = seq.transpose(0, 1).reshape(num_seqs * seq_length, -1)
            if norm is not None:
                out = norm(out)
            if self.rnn_concat_output:
                out = torch.cat([out, cnn_out], dim=1)
            if self.is_rnn_before_mlp:
                out = mlp(out)
            return out, (tuple(states) if isinstance(states, (tuple, list)) else (states,))

        def forward(self, obs_dict: dict) -> tuple:
            obs = obs_dict["obs"]
            states = obs_dict.get("rnn_states", None)
            if self.has_cnn and self.permute_input and obs.dim() == 4:
                obs = obs.permute(0, 3, 1, 2)  # (B, H, W, C) -> (B, C, H, W)
            if self.separate:
                a_states = c_states = None
                if self.has_rnn and states:
                    half = 1 if len(states) == 2 else 2  # GRU: (a_h, c_h); LSTM: (a_h, a_c, c_h, c_c)
                    a_states, c_states = tuple(states[:half]), tuple(states[half:])
                a_out, a_states = self._trunk(obs, self.actor_cnn, self.actor_mlp, getattr(self, "a_rnn", None),
                                              getattr(self, "a_layer_norm", None), a_states, obs_dict)
                c_out, c_states = self._trunk(obs, self.critic_cnn, self.critic_mlp, getattr(self, "c_rnn", None),
                                              getattr(self, "c_layer_norm", None), c_states, obs_dict)
                if self.has_rnn:
                    states = a_states + c_states
            else:
                a_out, states = self._trunk(obs, self.actor_cnn, self.actor_mlp, getattr(self, "rnn", None),
                                            getattr(self, "layer_norm", None), states, obs_dict)
                c_out = a_out
            value = self.value_act(self.value(c_out))
            if self.central_value:
                return value, states
            if self.is_discrete:
                return self.logits(a_out), value, states
            if self.is_multi_discrete:
                return [head(a_out) for head in self.logits], value, states
            if self.is_continuous:
                mu = self.mu_act(self.mu(a_out))
                if self.fixed_sigma:
                    sigma = self.sigma_act(self.sigma).expand_as(mu)
                else:
                    sigma = self.sigma_act(self.sigma(a_out))
                return mu, sigma, value, states
            return value, states

        def is_separate_critic(self) -> bool:
            return self.separate

        def is_rnn(self) -> bool:
            return self.has_rnn

        def get_default_rnn_state(self) -> tuple[torch.Tensor, ...] | None:
            """Zero states, each (layers, num_seqs, units): (h, c) per trunk for an LSTM, h for a GRU; actor's first."""
            if not self.has_rnn:
                return None
            units = 1 if self.rnn_name == "identity" else self.rnn_units
            per_trunk = 2 if self.rnn_name == "lstm" else 1
            count = per_trunk * (2 if self.separate else 1)
            return tuple(torch.zeros(self.rnn_layers, self.num_seqs, units) for _ in range(count))

        def load(self, params: Any) -> None:
            """Read the network block into the attributes the constructor and ``forward`` use."""
            self._load_mlp_block(params, separate=False)
            self.has_rnn = "rnn" in params
            self.has_space = "space" in params
            self.central_value = params.get("central_value", False)
            self.joint_obs_actions_config = params.get("joint_obs_actions", None)
            space = params["space"] if self.has_space else {}
            self.is_multi_discrete = "multi_discrete" in space
            self.is_discrete = "discrete" in space
            self.is_continuous = "continuous" in space
            if self.is_continuous:
                self.space_config = space["continuous"]
                self.fixed_sigma = self.space_config["fixed_sigma"]
            elif self.is_discrete:
                self.space_config = space["discrete"]
            elif self.is_multi_discrete:
                self.space_config = space["multi_discrete"]
            if self.has_rnn:
                rnn = params["rnn"]
                self.rnn_units = rnn["units"]
                self.rnn_layers = rnn["layers"]
                self.rnn_name = rnn["name"]
                self.rnn_ln = rnn.get("layer_norm", False)
                self.is_rnn_before_mlp = rnn.get("before_mlp", False)
                self.rnn_concat_input = rnn.get("concat_input", False)
                self.rnn_concat_output = rnn.get("concat_output", False)
            self.has_cnn = "cnn" in params
            if self.has_cnn:
                self.cnn = params["cnn"]
                self.permute_input = self.cnn.get("permute_input", True)


class DiagGaussianActor(BaseNetwork):
    """SAC's actor: an MLP to (mu, log_std) per action; ``forward(obs)`` returns the tanh-squashed Normal with
    log_std squashed into ``log_std_bounds`` by a tanh (rl_games' soft bound)."""

    def __init__(self, output_dim: int, log_std_bounds: Any, **mlp_args: Any) -> None:
        super().__init__()
        self.log_std_bounds = log_std_bounds
        trunk = self._build_mlp(**mlp_args)
        last = [m for m in trunk.modules() if isinstance(m, nn.Linear)][-1].out_features
        self.trunk = nn.Sequential(*trunk.children(), nn.Linear(last, output_dim))

    def forward(self, obs: torch.Tensor) -> SquashedNormal:
        mu, log_std = self.trunk(obs).chunk(2, dim=-1)
        low, high = self.log_std_bounds
        log_std = low + 0.5 * (high - low) * (torch.tanh(log_std) + 1)
        return SquashedNormal(mu, log_std.exp())


class DoubleQCritic(BaseNetwork):
    """SAC's twin critics: ``forward(obs, action)`` -> (q1, q2), each (B, output_dim)."""

    def __init__(self, output_dim: int, **mlp_args: Any) -> None:
        super().__init__()
        self.Q1 = self._head(output_dim, mlp_args)
        self.Q2 = self._head(output_dim, mlp_args)

    def _head(self, output_dim: int, mlp_args: dict) -> nn.Sequential:
        trunk = self._build_mlp(**mlp_args)
        last = [m for m in trunk.modules() if isinstance(m, nn.Linear)][-1].out_features
        return nn.Sequential(*trunk.children(), nn.Linear(last, output_dim))

    def forward(self, obs: torch.Tensor, action: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.cat([obs, action], dim=-1)
        return self.Q1(x), self.Q2(x)


class SACBuilder(NetworkBuilder):
    """rl_games' ``soft_actor_critic`` network builder: ``Network`` holds ``actor``, ``critic`` and
    ``critic_target`` (build kwargs ``obs_dim``, ``action_dim``; rlchain passes them)."""

    def __init__(self, **kwargs: Any) -> None:
        NetworkBuilder.__init__(self)

    def load(self, params: Any) -> None:
        self.params = params

    def build(self, name: str, **kwargs: Any) -> nn.Module:
        return SACBuilder.Network(self.params, **kwargs)

    class Network(BaseNetwork):
        def __init__(self, params: Any, **kwargs: Any) -> None:
            kwargs.pop("actions_num", None)
            kwargs.pop("input_shape", None)
            obs_dim, action_dim = kwargs.pop("obs_dim"), kwargs.pop("action_dim")
            self.num_seqs = kwargs.pop("num_seqs", 1)
            BaseNetwork.__init__(self)
            self.load(params)
            mlp_args = {"units": self.units, "activation": self.activation, "norm_func_name": self.normalization,
                        "dense_func": nn.Linear, "d2rl": self.is_d2rl,
                        "norm_only_first_layer": self.norm_only_first_layer}
            self.actor = self._build_actor(2 * action_dim, self.log_std_bounds, input_size=obs_dim, **mlp_args)
            if self.separate:
                self.critic = self._build_critic(1, input_size=obs_dim + action_dim, **mlp_args)
                self.critic_target = self._build_critic(1, input_size=obs_dim + action_dim, **mlp_args)
                self.critic_target.load_state_dict(self.critic.state_dict())
            mlp_init = self.init_factory.create(**self.initializer)
            for module in self.modules():
                if isinstance(module, nn.Linear):
                    mlp_init(module.weight)
                    if module.bias is not None:
                        nn.init.zeros_(module.bias)

        def _build_critic(self, output_dim: int, **mlp_args: Any) -> nn.Module:
            return DoubleQCritic(output_dim, **mlp_args)

        def _build_actor(self, output_dim: int, log_std_bounds: Any, **mlp_args: Any) -> nn.Module:
            return DiagGaussianActor(output_dim, log_std_bounds, **mlp_args)

        def forward(self, obs_dict: dict) -> Any:
            return self.actor(obs_dict["obs"])

        def is_separate_critic(self) -> bool:
            return self.separate

        def load(self, params: Any) -> None:
            self._load_mlp_block(params, separate=True)
            self.log_std_bounds = params.get("log_std_bounds", None)


__all__ = ["NetworkBuilder", "A2CBuilder", "SACBuilder", "DiagGaussianActor", "DoubleQCritic"]
