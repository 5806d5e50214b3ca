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

import dataclasses
import typing
from typing import Any

import torch
import torch.nn as nn

from rlchain.config import compat
from rlchain.config.fields import parse_dataclass
from rlchain.config.network import InitializerConfig, MlpConfig, NetworkConfig
from rlchain.networks import NetworkBuilder as _RlchainBuilder
from rlchain.networks.actor_critic import ActorCriticNetwork
from rlchain.networks.sac_network import SACActor, TwinQCritic
from rlchain.rl_games.algos_torch.base_network import BaseNetwork
from rlchain.rl_games.algos_torch.sac_helper import SquashedNormal
from rlchain.rl_games.algos_torch.torch_ext import shape_whc_to_cwh

SOURCE = "A2CBuilder.Network"  # where a bad value of a block built here is reported from


class NetworkBuilder(_RlchainBuilder):
    """A builder: ``load(params)`` keeps the network block, ``build(name, **kwargs)`` returns the module."""

    BaseNetwork = BaseNetwork


class A2CBuilder(NetworkBuilder):
    """rl_games' ``actor_critic`` network builder."""

    def build(self, name: str, **kwargs: Any) -> nn.Module:
        return A2CBuilder.Network(self.params, **kwargs)

    class Network(ActorCriticNetwork, BaseNetwork):
        """rlchain's actor-critic network (:class:`rlchain.networks.actor_critic.ActorCriticNetwork`) built from a
        plain network block, with rl_games' attributes read from it (:meth:`load`) and ``BaseNetwork``'s helpers.

        Build kwargs: ``actions_num`` (a list of sizes for multi-discrete), ``input_shape``, ``value_size``,
        ``num_seqs`` (the batch of ``get_default_rnn_state()``); others are ignored. The block's keys are
        rlchain's ``actor_critic`` keys (rl_games' and rlchain's own options); keys it does not know are left to
        a subclass (unread ones are a warning). Where rlchain's network differs from rl_games' (docs/rl_games.md):
        it initializes each layer as it builds it (the ``default`` initializer keeps torch's bias; rl_games zeroes
        every bias), ``actor_cnn`` flattens its output, D2RL keeps rlchain's layout, and ``normalization`` applies
        to the MLP only.
        """

        def __init__(self, params: Any, **kwargs: Any) -> None:
            actions_num = kwargs.pop("actions_num")
            input_shape = tuple(kwargs.pop("input_shape"))
            value_size = kwargs.pop("value_size", 1)
            cfg = typed_block(params)
            space = cfg.space
            sizes = [int(n) for n in actions_num] if isinstance(actions_num, (list, tuple)) else None
            if cfg.cnn is not None and cfg.cnn.permute_input:  # rl_games permutes in forward (split_obs)
                input_shape = shape_whc_to_cwh(input_shape)
                cfg = dataclasses.replace(cfg, cnn=dataclasses.replace(cfg.cnn, permute_input=False))
            no_head = space.discrete is None and space.multi_discrete is None and space.continuous is None
            ActorCriticNetwork.__init__(self, cfg, input_shape, sum(sizes) if sizes else int(actions_num),
                                        value_size, space.continuous is not None,
                                        central_value=cfg.central_value or no_head,
                                        logits_sizes=sizes if space.multi_discrete is not None else None,
                                        num_seqs=kwargs.pop("num_seqs", 1))
            self.value_size = value_size
            sigma = getattr(self, "sigma", None)
            if isinstance(sigma, nn.Linear) and space.continuous.sigma_init.name == "const_initializer":
                with torch.no_grad():  # rl_games 2.0: a constant initial std whatever the input
                    sigma.weight.zero_()
                    sigma.bias.fill_(space.continuous.sigma_init.val)
            self.load(params)
            for name in ("actor_cnn", "critic_cnn", "actor_mlp", "critic_mlp"):  # rl_games' empty defaults
                if not hasattr(self, name):
                    setattr(self, name, nn.Sequential())

        def split_obs(self, obs: torch.Tensor) -> tuple[torch.Tensor, None]:
            if self.has_cnn and self.permute_input and obs.dim() == 4:
                obs = obs.permute(0, 3, 1, 2)  # (B, H, W, C) -> (B, C, H, W), as rl_games' forward does
            return obs, None

        def load(self, params: Any) -> None:
            """Read the network block into the attributes rl_games' network has (``units``, ``space_config``,
            ``has_rnn``, ``rnn_units``, ...): subclasses read them."""
            self._load_mlp_block(params, separate=False)
            self.has_rnn = "rnn" in params
            self.has_space = "space" in params
            self.central_value = params.get("central_value", False) or self.central_value
            self.joint_obs_actions_config = params.get("joint_obs_actions", None)
            space = params["space"] if self.has_space else {}
            self.is_multi_discrete = "multi_discrete" in space
            self.is_discrete = "discrete" in space
            self.is_continuous = "continuous" in space
            if self.is_continuous:
                self.space_config = space["continuous"]
                self.fixed_sigma = self.space_config.get("fixed_sigma", self.fixed_sigma)
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


def typed_block(params: Any) -> NetworkConfig:
    """The ``actor_critic`` keys of a plain network block as rlchain's typed NetworkConfig (a one-line error
    naming a bad value); the keys it does not know are not read, so a subclass may read them (and an unread
    one is a warning)."""
    block = compat.translate_network(_known(NetworkConfig, params), SOURCE)
    block.pop("name", None)  # the registered name of the builder, not a choice of the network
    return parse_dataclass(NetworkConfig, block, "params.network", SOURCE)


def _known(cls: type, block: Any) -> dict:
    """The entries of ``block`` (a dict) that are fields of the dataclass ``cls``, nested dataclass blocks
    likewise; read key by key so a tracked block (rlchain.networks.base.ReadKeys) marks only those."""
    out = {}
    hints = typing.get_type_hints(cls)
    aliases = list(compat.INITIALIZER_ALIASES) if cls is InitializerConfig else []  # rl_games 2.0's ``value``
    for name in [field.name for field in dataclasses.fields(cls)] + aliases:
        if name not in block:
            continue
        value = block[name]
        hint = hints.get(name)
        inner = [t for t in (hint, *typing.get_args(hint)) if dataclasses.is_dataclass(t)]
        out[name] = _known(inner[0], value) if inner and isinstance(value, dict) else value
    return out


def _mlp_config(mlp_args: dict) -> MlpConfig:
    """rl_games' ``_build_mlp`` arguments as the MlpConfig of rlchain's MLP (Linear, activation, norm per layer;
    the weights as torch draws them: SACBuilder.Network initializes them after the build, as rl_games does)."""
    block = {"units": list(mlp_args["units"]), "activation": mlp_args["activation"],
             "normalization": mlp_args.get("norm_func_name"), "norm_after_activation": True,
             "d2rl": bool(mlp_args.get("d2rl", False)),
             "norm_only_first_layer": bool(mlp_args.get("norm_only_first_layer", False))}
    return parse_dataclass(MlpConfig, block, "params.network.mlp", SOURCE)


class DiagGaussianActor(SACActor, BaseNetwork):
    """SAC's actor, rlchain's (:class:`rlchain.networks.sac_network.SACActor`: one ``trunk`` Sequential to
    (mu, log_std) per action, log_std squashed into ``log_std_bounds`` by a tanh) built from rl_games' arguments;
    ``forward(obs)`` returns rl_games' tanh-squashed Normal."""

    def __init__(self, output_dim: int, log_std_bounds: Any, **mlp_args: Any) -> None:
        if log_std_bounds is None:
            raise ValueError("params.network.log_std_bounds: SAC's actor needs [low, high] (e.g. [-5, 2])")
        SACActor.__init__(self, mlp_args["input_size"], output_dim // 2, _mlp_config(mlp_args), log_std_bounds)

    def forward(self, obs: torch.Tensor) -> SquashedNormal:
        mu, log_std = SACActor.forward(self, obs)
        return SquashedNormal(mu, log_std.exp())


class DoubleQCritic(TwinQCritic, BaseNetwork):
    """SAC's twin critics, rlchain's (:class:`rlchain.networks.sac_network.TwinQCritic`: ``Q1`` / ``Q2``) built
    from rl_games' arguments (``input_size``: observation and action together); ``forward(obs, action)`` ->
    (q1, q2), each (B, 1) as rl_games returns them."""

    def __init__(self, output_dim: int, **mlp_args: Any) -> None:
        if output_dim != 1:
            raise ValueError(f"DoubleQCritic: one Q-value per critic, got output_dim={output_dim}")
        TwinQCritic.__init__(self, mlp_args["input_size"], 0, _mlp_config(mlp_args))

    def forward(self, obs: torch.Tensor, action: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.cat([obs, action], dim=-1)
        return self.Q1(x), self.Q2(x)


class SACBuilder(NetworkBuilder):
    """rl_games' ``soft_actor_critic`` network builder: ``Network`` holds ``actor``, ``critic`` and
    ``critic_target`` (build kwargs ``obs_dim``, ``action_dim``; rlchain passes them)."""

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
