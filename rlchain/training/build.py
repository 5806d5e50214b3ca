"""Turn typed Params into live parts: device, vectorized env, model (network + distribution)."""

from __future__ import annotations

import warnings
from typing import Any

import torch

from rlchain.config.errors import ConfigError
from rlchain.config.schema import Params
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import actions_num as action_head_size
from rlchain.networks.base import instantiate
from rlchain.registry import MODELS, NETWORKS


def resolve_device(name: str) -> torch.device:
    """``cpu`` / ``cuda`` / ``cuda:N``; without CUDA a cuda device falls back to cpu with a warning."""
    if name.startswith("cuda") and not torch.cuda.is_available():
        warnings.warn(f"params.config.device is '{name}' but CUDA is not available; training on cpu",
                      stacklevel=2)
        return torch.device("cpu")
    try:
        return torch.device(name)
    except RuntimeError:
        raise ConfigError("", "params.config.device", f"'{name}' is not a device (cpu, cuda, cuda:N)") from None


def build_env(params: Params, num_envs: int, seed: int | None, render: bool = False,
              env_config: dict | None = None) -> Any:
    """Make the vectorized env the config names; env errors come back naming the file."""
    from rlchain.envs.factory import make_vec_env

    cfg = params.config
    merged = dict(cfg.env_config)
    merged.update(env_config or {})
    try:
        return make_vec_env(cfg.env_name, merged, num_envs, seed, cfg.vecenv_type, render=render)
    except ValueError as exc:
        raise ConfigError(params.source, "", str(exc)) from None


def value_size_of(env: Any) -> int:
    return int(getattr(env, "value_size", 1))


def build_model(params: Params, env: Any, device: torch.device) -> ActorCritic:
    """Network from the network registry, wrapped by the model preset from the model registry."""
    obs_space, act_space = env.observation_space, env.action_space
    factory = MODELS.get(params.model.name)
    value_size = value_size_of(env)
    actions_num = action_head_size(act_space)  # n, sum(nvec) or prod(Box shape)
    try:
        network = instantiate(NETWORKS.get(_network_name(params.network)), params.network,
                              actions_num=actions_num, input_shape=tuple(obs_space.shape),
                              value_size=value_size, num_seqs=params.config.num_actors,
                              action_space=act_space, observation_space=obs_space)
        model = factory(network=network, action_space=act_space, obs_shape=tuple(obs_space.shape),
                        value_size=value_size, config=params.config, model_name=params.model.name)
    except ValueError as exc:
        raise ConfigError(params.source, "", str(exc)) from None
    return model.to(device)


def _network_name(network: Any) -> str:
    return network.name if hasattr(network, "name") else network.get("name", "actor_critic")


def apply_sigma(model: Any, sigma: float) -> None:
    """``--sigma``: a one-line ConfigError when the policy has no fixed sigma to set."""
    try:
        model.override_sigma(sigma)
    except ValueError as exc:
        raise ConfigError("", "--sigma", str(exc)) from None
