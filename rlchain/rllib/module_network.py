"""A user's ``RLModule`` (``rl_module(rl_module_spec=RLModuleSpec(module_class=...))``) as an rlchain network.

:func:`register` builds the module class on the env's spaces and ``model_config`` and registers it under a fresh
network name, so rlchain's PPO trains it like any network: :class:`RLModuleNetwork` feeds the module RLlib's
batch (``{"obs": ...}``, a dict of tensors for Dict observations) and hands the outputs to rlchain's
distribution: ``action_dist_inputs`` are the logits (Discrete) or means then log-stds (Box, RLlib's diagonal
Gaussian, as rlchain's ``continuous_a2c_logstd`` model reads them); ``compute_values`` is the value.

The calls follow RLlib's PPO: a rollout step is ``forward_exploration`` then ``compute_values``; a training pass
is ``forward_train`` then ``compute_values(batch, embeddings)`` with the embeddings it returned. With Dict
observations the values come first, as RLlib's learner computes them (the GAE pass) before ``forward_train`` on
the same batch (RLlib's action-masking module relies on that order).
"""

from __future__ import annotations

import dataclasses
import inspect
import itertools
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import torch
from torch import nn

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.pettingzoo_env import flat_space
from rlchain.model_builder import register_network
from rlchain.rllib import keys as K
from rlchain.rllib.core import DEFAULT_MODULE_ID
from rlchain.rllib.core.columns import Columns
from rlchain.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
from rlchain.rllib.default_ppo_module import DefaultPPOTorchRLModule
from rlchain.rllib.module import NAME_PREFIX, RLModuleSpec
from rlchain.rllib.multi_agent import policy_names, trained_policies
from rlchain.rllib.networks import actor_critic_network

_COUNTER = itertools.count(1)


class RLModuleNetwork(nn.Module):
    """An RLModule under rlchain's network call: ``forward({"obs": ...}) -> (logits, value, None)`` or, for Box
    actions, ``(means, log_stds, value, None)``."""

    def __init__(self, module: nn.Module, continuous: bool, action_space: gym.Space | None = None,
                 trained: bool = True, where: str = "rl_module()",
                 unflatten: Callable[[torch.Tensor], torch.Tensor] | None = None) -> None:
        super().__init__()
        self.module = module
        self.unflatten = unflatten  # the module's own observations from the flat rows it is fed
        self.continuous = continuous
        self.action_space = action_space
        name = type(module).__name__
        if module.is_stateful() if callable(getattr(module, "is_stateful", None)) else False:
            raise ConfigError(where, "rl_module_spec", f"{name} is stateful (get_initial_state): recurrent RLModules "
                                                       f"are not trained by the face; write an rlchain YAML with an "
                                                       f"rnn block (docs/config.md)")
        compute = getattr(module, "compute_values", None)
        self._has_values = callable(compute)
        if trained and not self._has_values:
            raise ConfigError(where, "rl_module_spec", f"{name} has no compute_values: PPO needs a module with "
                                                       f"ValueFunctionAPI (compute_values(batch, embeddings=None)); "
                                                       f"a module that only acts must be left out of "
                                                       f"policies_to_train")
        try:
            self._takes_embeddings = self._has_values and "embeddings" in inspect.signature(compute).parameters
        except (TypeError, ValueError):
            self._takes_embeddings = False

    def _values(self, batch: dict[str, Any], embeddings: Any = None) -> torch.Tensor:
        if not self._has_values:  # a frozen module that only acts (a heuristic opponent): no value to learn
            obs = batch[Columns.OBS]
            rows = next(iter(obs.values())) if isinstance(obs, dict) else obs
            return torch.zeros(rows.shape[0])
        if self._takes_embeddings and embeddings is not None:
            return self.module.compute_values(batch, embeddings=embeddings)
        return self.module.compute_values(batch)

    def forward(self, inputs: dict[str, Any]) -> tuple:
        obs = inputs["obs"]
        if self.unflatten is not None:
            obs = self.unflatten(obs)
        batch = {Columns.OBS: dict(obs) if isinstance(obs, dict) else obs}
        if inputs.get("is_train"):
            if isinstance(obs, dict):
                values = self._values(batch)
                out = self.module.forward_train(batch)
            else:
                out = self.module.forward_train(batch)
                values = self._values(batch, out.get(Columns.EMBEDDINGS))
        else:
            out = self.module.forward_exploration(batch)
            values = self._values(batch, out.get(Columns.EMBEDDINGS))
        if Columns.ACTION_DIST_INPUTS in out:
            params = out[Columns.ACTION_DIST_INPUTS]
        elif Columns.ACTIONS in out:  # the module chose the actions itself: a distribution that picks them
            params = self._picking(out[Columns.ACTIONS], values.device)
        else:
            raise ValueError(f"{type(self.module).__name__}'s forward returned {sorted(out)}: no "
                             f"'{Columns.ACTION_DIST_INPUTS}' or '{Columns.ACTIONS}'")
        value = values.reshape(values.shape[0], -1) if values.dim() != 2 else values
        value = value.to(params.device)
        if self.continuous:
            mean, log_std = params.chunk(2, dim=-1)
            return mean, log_std, value, None
        return params, value, None


    def _picking(self, actions: Any, device: torch.device) -> torch.Tensor:
        """Distribution inputs whose sample and mode are ``actions``: logits 0 on the action and -1e9 elsewhere
        (Discrete), or the actions as means with a negligible std (Box)."""
        actions = torch.as_tensor(actions, device=device)
        if self.continuous:
            mean = actions.float().reshape(actions.shape[0], -1)
            return torch.cat([mean, torch.full_like(mean, -20.0)], -1)
        logits = torch.full((actions.shape[0], int(self.action_space.n)), -1e9, device=device)
        return logits.scatter(1, actions.long().reshape(-1, 1), 0.0)


def register(spec: Any, observation_space: gym.Space, action_space: gym.Space, model_config: dict[str, Any],
             trained: bool = True, where: str = "rl_module()") -> str:
    """A fresh network name whose builder makes ``spec.module_class`` on these spaces (the spec's own spaces when
    it gives them) with ``model_config``, wrapped in :class:`RLModuleNetwork` (``where``: what its config errors
    name, the user's ``PPOConfig.rl_module()``)."""
    module_class = spec.module_class
    obs_space = spec.observation_space or observation_space
    act_space = spec.action_space or action_space
    continuous = isinstance(act_space, gym.spaces.Box)
    unflatten = None if spec.observation_space is None else unflattener(spec.observation_space, observation_space)

    def build(block: Any, **kwargs: Any) -> RLModuleNetwork:
        module = module_class(observation_space=obs_space, action_space=act_space, inference_only=False,
                              learner_only=False, model_config=dict(model_config), catalog_class=spec.catalog_class)
        if not isinstance(module, nn.Module):
            raise ConfigError(where, "rl_module_spec", f"{module_class.__name__} is not a torch module: subclass "
                                                       f"TorchRLModule")
        return RLModuleNetwork(module, continuous, act_space, trained, where, unflatten)

    build.takes_dict_obs = isinstance(observation_space, gym.spaces.Dict)
    name = f"{NAME_PREFIX}{next(_COUNTER)}"
    register_network(name, build)
    return name


def unflattener(declared: gym.Space, fed: gym.Space) -> Callable[[torch.Tensor], torch.Tensor] | None:
    """For a module that declares its observation space ``declared`` but is fed ``fed``, gymnasium's flat rows of
    it (rlchain's PettingZoo backend flattens every policy's observations: Discrete one-hot): a batch of the
    module's own observations back (Discrete: the index; MultiDiscrete: each part's; Box: its shape). None when
    the module is fed its own space or another space than those (it gets the rows as they come)."""
    if declared == fed or not (isinstance(fed, gym.spaces.Box) and len(fed.shape) == 1) or \
            fed.shape[0] != gym.spaces.flatdim(declared):
        return None
    if isinstance(declared, gym.spaces.Discrete):
        start = int(declared.start)
        return lambda x: x.argmax(-1) + start
    if isinstance(declared, gym.spaces.MultiDiscrete) and declared.nvec.ndim == 1:
        sizes = [int(n) for n in declared.nvec]
        starts = torch.as_tensor(declared.start)
        return lambda x: torch.stack([part.argmax(-1) for part in x.split(sizes, -1)], -1) + starts
    if isinstance(declared, gym.spaces.Box) and len(declared.shape) > 1:
        shape = declared.shape
        return lambda x: x.reshape(x.shape[0], *shape)
    return None


def apply_spec(config: Any, rlchain_config: dict[str, Any], observation_space: gym.Space,
               action_space: gym.Space) -> None:
    """Put the config's ``rl_module_spec`` into ``rlchain_config`` (PPO): a module class as the network; a spec
    with only ``model_config`` is RLlib's default PPO module on that config; neither changes nothing."""
    spec = config._settings.get("rl_module_spec")
    if spec is None:
        return
    if isinstance(spec, MultiRLModuleSpec):
        spec = spec.spec_of(DEFAULT_MODULE_ID)
        if spec is None:
            return
    params = rlchain_config["params"]
    params["network"] = network_block(config, spec, observation_space, action_space) or params["network"]


def network_block(config: Any, spec: Any, observation_space: gym.Space, action_space: gym.Space,
                  trained: bool = True) -> dict[str, Any] | None:
    """The network block of one module spec (None: the face's own network from ``model_config``)."""
    where = f"{type(config).__name__}.rl_module()"
    if not isinstance(spec, RLModuleSpec):
        raise ConfigError(where, "rl_module_spec", f"expected an RLModuleSpec or MultiRLModuleSpec, got "
                                                   f"{type(spec).__name__}")
    if spec.module_class is None and spec.model_config is None:
        return None
    if spec.load_state_path is not None:
        raise ConfigError(where, "rl_module_spec.load_state_path", "RLlib's module state files are not read: "
                                                                   "restore an rlchain checkpoint")
    own = spec.model_config
    own = dataclasses.asdict(own) if dataclasses.is_dataclass(own) else dict(own or {})
    module_class = spec.module_class
    if module_class is None:  # RLlib's default PPO module on the spec's model_config
        module_class = DefaultPPOTorchRLModule
    if not (isinstance(module_class, type) and issubclass(module_class, nn.Module)):
        raise ConfigError(where, "rl_module_spec.module_class", f"{module_class!r}: expected a TorchRLModule "
                                                                f"subclass")
    spec = dataclasses.replace(spec, module_class=module_class)
    auto = K.ALGO_DEFAULTS.get(config.algo_name, {}).get("model_config", {})  # RLlib's auto-included keys
    settings = config._settings
    model_config = {**auto, **(settings.get("model") or {}), **(settings.get("model_config") or {}), **own}
    name = register(spec, observation_space, action_space, model_config, trained, where)
    return {"name": name}



def policy_network(config: Any, policy: str, observation_space: gym.Space, action_space: gym.Space
                   ) -> dict[str, Any]:
    """The network block of one multi-agent policy: its module spec's (``MultiRLModuleSpec(rl_module_specs=
    {policy: RLModuleSpec(...)})`` or one ``RLModuleSpec`` for all), else the face's network from
    ``model_config``. The policy's observations arrive flattened (rlchain's PettingZoo backend)."""
    spec = config._settings.get("rl_module_spec")
    if isinstance(spec, MultiRLModuleSpec):
        spec = spec.spec_of(policy)
    flat = flat_space(observation_space)[0]
    to_train = trained_policies(config, policy_names(config)[0])
    trained = to_train is None or policy in to_train
    block = None if spec is None else network_block(config, spec, flat, action_space, trained)
    if block is not None:
        return block
    network, _ = actor_critic_network(config, flat, isinstance(action_space, gym.spaces.Box))
    return network  # with use_lstm, an rnn block; the shared config's seq_length cuts its sequences
