"""Turn typed Params into a model (network + distribution), one per policy, and the central value."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.config.errors import ConfigError
from rlchain.config.multi_agent import KEY, PolicyMapping
from rlchain.config.multi_input import MultiInputNetworkConfig
from rlchain.config.network import NetworkConfig
from rlchain.config.network_block import network_name
from rlchain.config.params import Params
from rlchain.envs.factory import build_env  # noqa: F401  (importable from here too)
from rlchain.envs.gym_spaces import to_gymnasium
from rlchain.envs.obs_dict import flat_size, is_dict_space
from rlchain.envs.obs_groups import ObsView, group_parts, resolve_view
from rlchain.envs.spec import env_spec
from rlchain.envs.wrappers.central_value import obs_state_split
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.base import ObservationModel
from rlchain.models.central_value import CentralValue
from rlchain.models.distributions import actions_num as action_head_size
from rlchain.models.size import build_within_memory
from rlchain.networks.base import instantiate
from rlchain.parallel.device import resolve_device  # noqa: F401  (importable from here too)
from rlchain.registry import MODELS, NETWORKS


def value_size_of(env: Any) -> int:
    """The value head size of ``env`` (a VecEnv or a policy's view of one): its spec's ``value_size``."""
    return env_spec(env).value_size


def model_view(params: Params, space: gym.Space, group: str | None = None, groups: Any = None) -> ObsView:
    """What the model of ``params`` reads of the flat observation space ``space``: the ``obs_groups`` group
    its algorithm trains (PPO: ``obs_groups.policy``; distill: ``student``) or ``group``; ``groups``
    overrides the config's block (distill builds its teacher with its own run's groups)."""
    cfg = params.config
    groups = getattr(cfg, "obs_groups", None) if groups is None else groups
    if group is None:
        group = getattr(cfg, "model_group", None) or (groups.policy if groups is not None else "teacher")
    parts = group_parts(groups, group, space)
    return resolve_view(space, parts, group, f"params.config.obs_groups.{group}", params.source)


def build_model(params: Params, env: Any, device: torch.device, group: str | None = None,
                groups: Any = None) -> ActorCritic:
    """Network from the network registry, wrapped by the model preset from the model registry; with
    ``config.multi_agent``, a ModuleDict of one such model per policy (algos/multi_policy/policies.py).
    The model reads its observation group (:func:`model_view`; a central-value env's actor: ``obs``)."""
    if getattr(params, "policies", None) is not None:
        return build_policy_models(params, env, device)
    obs_space, act_space = to_gymnasium(env.observation_space, False), to_gymnasium(env.action_space, False)
    view = model_view(params, obs_space, group, groups)
    declared = declared_space(obs_space)  # the env's own (e.g. Dict) space, for networks that split by key
    if not view.whole and view.size:
        declared, obs_space = view.space, gym.spaces.Box(-np.inf, np.inf, (view.size,), np.float32)
    factory = MODELS.get(params.model.name)
    value_size = value_size_of(env)
    actions_num = action_head_size(act_space)  # n, sum(nvec) or prod(Box shape)
    builder = NETWORKS.get(network_name(params.network))
    # Dict observations kept per key: a multi-input network takes them as they are, any other one the keys
    # concatenated into one flat vector (the model does it, the storage still keeps every key's dtype)
    per_key = is_dict_space(obs_space) and getattr(builder, "takes_dict_obs", False)
    flatten = is_dict_space(obs_space) and not per_key
    shape = (flat_size(obs_space),) if flatten else None if per_key else tuple(obs_space.shape)

    # a network taking the keys apart builds its model's heads (actor-critic, SAC or DQN): it gets the model's name
    model_name = {"model_name": params.model.name} if per_key else {}

    def build() -> ActorCritic:
        network = instantiate(builder, params.network,
                              actions_num=actions_num, input_shape=obs_space if per_key else shape,
                              value_size=value_size, num_seqs=params.config.num_actors,
                              action_space=act_space, observation_space=declared, **model_name)
        return factory(network=network, action_space=act_space, obs_shape=obs_space if per_key else shape,
                       value_size=value_size, config=params.config, model_name=params.model.name)

    try:
        model = build_within_memory(build, device, params.source)
    except ConfigError:
        raise
    except ValueError as exc:
        key = f"params.config.obs_groups.{view.group}" if not view.whole and view.size else ""
        raise ConfigError(params.source, key, f"{'' if not key else 'the network cannot take this view: '}"
                                              f"{exc}") from None
    # the part of the observations the model reads: the registered factory's signature (rl_games') has no place
    # for it, so the builder completes the model with it, once, before anything uses the model (a duck-typed
    # user model, not an ObservationModel, reads its observations its own way)
    if isinstance(model, ObservationModel):
        named = getattr(params.config, "obs_groups", None) is not None or groups is not None
        part = bool(not view.whole and view.size)
        model.read_view(view.selector() if part else None, view.group if part and named else None, flatten)
    return model.to(device)


def build_central_value(params: Params, env: Any, device: torch.device) -> Any:
    """The asymmetric critic of ``central_value_config`` on its view: ``obs_groups.critic``, by default the
    env's state part."""
    cv = params.config.central_value_config
    if cv is None:
        return None
    space = env.observation_space
    if is_dict_space(space):  # Dict observations kept per key: a multi_input critic reads the keys it names
        return _dict_central_value(params, cv, space, value_size_of(env), device)
    groups = getattr(params.config, "obs_groups", None)
    if obs_state_split(space) is None and getattr(groups, "critic", None) is None:
        raise ConfigError(params.source, "params.config.central_value_config", "the env has no central-value "
                          "state: it must return {'obs': ..., 'state': ...} observations (use_central_value), "
                          "or obs_groups.critic must name the critic's part")
    view = model_view(params, space, "critic")
    state_shape = (view.size,)
    value_size = value_size_of(env)
    key = "params.config.central_value_config.network"

    def build() -> CentralValue:
        built_in = isinstance(cv.network, NetworkConfig)  # the built-in actor_critic trunk + value head
        network = None
        if not built_in:  # a registered network, given its block and rl_games' critic kwargs
            block = {"central_value": True, **cv.network} if isinstance(cv.network, dict) else cv.network
            network = instantiate(NETWORKS.get(network_name(cv.network)), block, key, actions_num=value_size,
                                  input_shape=state_shape, value_size=value_size,
                                  num_seqs=params.config.num_actors, observation_space=view.space)
        return CentralValue(cv.network if built_in else None, state_shape, value_size, cv.normalize_input,
                            params.config.normalize_value, network=network, obs_slice=view.selector(),
                            **_normalizer_kinds(params.config))

    try:
        model = build_within_memory(build, device, params.source, key)
    except ConfigError:
        raise
    except ValueError as exc:
        raise ConfigError(params.source, key, str(exc)) from None
    return model.to(device)


def _dict_central_value(params: Params, cv: Any, space: gym.spaces.Dict, value_size: int,
                        device: torch.device) -> CentralValue:
    """The asymmetric critic on Dict observations kept per key: a ``multi_input`` network whose ``inputs`` pick
    its keys (privileged state the actor's network leaves out with ``encoder: none``)."""
    if not isinstance(cv.network, MultiInputNetworkConfig):
        raise ConfigError(params.source, "params.config.central_value_config.network.name",
                          f"the observations are a Dict kept per key ({', '.join(space.spaces)}): the central "
                          f"value's network must be multi_input, its inputs naming the keys it reads")
    try:
        model = CentralValue(cv.network, space, value_size, cv.normalize_input, params.config.normalize_value,
                             obs_normalizer_exclude=tuple(getattr(params.config, "obs_normalizer_exclude", ())),
                             **_normalizer_kinds(params.config))
    except ValueError as exc:
        raise ConfigError(params.source, "params.config.central_value_config.network", str(exc)) from None
    return model.to(device)


@dataclass
class PolicyView:
    """What one policy sees of the env: its agents' (equal) spaces; ``value_size`` as VecEnvs have."""

    observation_space: gym.Space
    action_space: gym.Space
    mask_size: int
    value_size: int = 1


def policy_agents(params: Params, env: Any) -> dict[str, list[str]]:
    """policy name -> the env's agent ids it plays (policy_mapping; an unmapped agent is an error)."""
    ma = params.config.multi_agent
    mapping = PolicyMapping(ma.policy_mapping, list(params.policies), params.source)
    return mapping.assign(list(env.agent_ids))


def policy_view(params: Params, env: Any, name: str, agents: list[str]) -> PolicyView:
    """The spaces of the agents of ``name``; agents of one policy must share them."""
    first = agents[0]
    for other in agents[1:]:
        for what, spaces in (("observation", env.observation_spaces), ("action", env.action_spaces)):
            if spaces[other] != spaces[first]:
                raise ConfigError(params.source, f"{KEY}.policy_mapping",
                                  f"agents '{first}' and '{other}' both map to policy '{name}' but their "
                                  f"{what} spaces differ ({spaces[first]} vs {spaces[other]}); give them "
                                  f"separate policies")
    return PolicyView(env.observation_spaces[first], env.action_spaces[first], env.mask_sizes[first])


def build_policy_models(params: Params, env: Any, device: torch.device) -> torch.nn.ModuleDict:
    """One model per policy (``params.policies``), each built from its own network and model preset
    for its agents' spaces; a space the named network or model cannot take is a one-line ConfigError."""
    if not env_spec(env).pettingzoo:
        raise ConfigError(params.source, KEY, "needs env_name: pettingzoo (a PettingZoo env in env_config.env); "
                                              "rl_games-style multi-agent envs share one policy without it")
    models = torch.nn.ModuleDict()
    for name, agents in policy_agents(params, env).items():
        if not agents:
            continue  # a policy no agent plays (e.g. the opponent of a seat not in this env) is not built
        view = policy_view(params, env, name, agents)
        policy = params.policies[name]
        try:
            models[name] = build_model(policy, view, device)
        except (ConfigError, ValueError, TypeError, RuntimeError) as exc:
            detail = getattr(exc, "message", None) or " ".join(str(exc).split())
            raise ConfigError(params.source, f"{KEY}.policies.{name}",
                              f"network '{network_name(policy.network)}' / model '{policy.model.name}' do "
                              f"not fit agents {agents} (observations {view.observation_space}, actions "
                              f"{view.action_space}): {detail}") from None
    return models


def declared_space(space: gym.Space) -> gym.Space:
    """The observation space as the env declared it: the Dict behind a flattened one, else ``space``."""
    return getattr(space, "dict_space", None) or space


def _normalizer_kinds(cfg: Any) -> dict[str, str]:
    """The central value's normalizers as the run's config names them (its value_normalizer, obs_normalizer)."""
    return {"value_normalizer_kind": cfg.value_normalizer,
            "obs_normalizer_kind": getattr(cfg, "obs_normalizer", "rl_games")}


def apply_sigma(model: Any, sigma: float) -> None:
    """``--sigma``: a one-line ConfigError when the policy has no fixed sigma to set (every policy's,
    with config.multi_agent)."""
    if isinstance(model, torch.nn.ModuleDict):
        for policy in model.values():
            apply_sigma(policy, sigma)
        return
    try:
        model.override_sigma(sigma)
    except ValueError as exc:
        raise ConfigError("", "--sigma", str(exc)) from None
