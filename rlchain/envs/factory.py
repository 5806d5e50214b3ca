"""Turn ``params.config.env_name`` / ``env_config`` / ``vecenv_type`` into a VecEnv, like rl_games.

The envs of this process are built by :mod:`rlchain.envs.building` (how ``env_name`` is resolved,
the gymnasium / envpool / brax / pettingzoo backends); ``vecenv_type: RAY`` or an ``env_runners``
block puts them on Ray workers (:mod:`rlchain.envs.ray.ray_env`), each building its slice with that same
module. Either way the VecEnv returned carries its :class:`~rlchain.envs.spec.EnvSpec` as
``env.env_spec`` (agents, value size, mask size, tensor env, groups, ...), read once here.
Config mistakes raise :class:`ConfigError` (a ValueError) naming the key path; the caller adds
the file name.
"""

from __future__ import annotations

from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.network_block import network_name
from rlchain.config.params import Params
from rlchain.envs.building import (
    RL_GAMES_ENVPOOL_KEYS,
    VECENV_TYPES,
    _no_groups,
    build_local_env,
    envpool_env,
    normalize_vecenv_type,
    openai_gym_env,
    resolve_env_groups,
)
from rlchain.envs.ray.ray_env import make_ray_vec_env
from rlchain.envs.spec import attach_spec
from rlchain.envs.vecenv import VecEnv
from rlchain.envs.wrappers.dict_obs import FlatDictBox, per_key_obs
from rlchain.registry import NETWORKS


def make_vec_env(env_name: str, env_config: dict | None, num_envs: int, seed: int | None,
                 vecenv_type: str | None, render: bool = False, env_runners: Any = None,
                 groups: Any = 1) -> VecEnv:
    """Build ``num_envs`` envs named ``env_name`` (see :mod:`rlchain.envs.building`), seeded from
    ``seed``, with their :class:`~rlchain.envs.spec.EnvSpec` attached as ``env.env_spec``.

    ``env_config.seed``, when present, replaces ``seed`` (rl_games envpool configs). ``render=True``
    asks for ``render_mode='human'`` (the Player). The VecEnv's first ``reset()`` uses ``seed``.
    ``vecenv_type: RAY`` or ``env_runners`` (an EnvRunnersConfig) steps them on Ray workers.
    ``groups`` (``env_groups``: auto or an int) splits envpool envs into groups that step in the
    background (see ``EnvpoolVecEnv``); other backends take only 1 or auto.
    """
    kind = normalize_vecenv_type(vecenv_type, env_name)
    if kind == "ray" or env_runners is not None:
        _no_groups(groups, "Ray env runners")
        env = make_ray_vec_env(env_name, env_config, num_envs, seed, kind, env_runners, render)
    else:
        env = build_local_env(env_name, env_config, num_envs, seed, kind, render, groups)
    return attach_spec(env)


class BuiltinVecEnv:
    """The creator registered for a built-in ``vecenv_type`` (rl_games' signature ``(config_name,
    num_actors, **env_config)``): builds with its ``builtin_mode`` (auto, sync, async, native, envpool, ray)."""

    def __init__(self, mode: str) -> None:
        self.builtin_mode = mode

    def __call__(self, config_name: str, num_actors: int, seed: int | None = None, render: bool = False,
                 **env_config: Any) -> VecEnv:
        return make_vec_env(config_name, env_config, num_actors, seed, self.builtin_mode, render=render)


__all__ = ["make_vec_env", "normalize_vecenv_type", "openai_gym_env", "envpool_env", "resolve_env_groups",
           "RL_GAMES_ENVPOOL_KEYS", "VECENV_TYPES", "BuiltinVecEnv"]


def build_env(params: Params, num_envs: int, seed: int | None, render: bool = False,
              env_config: dict | None = None, runners: bool = False, groups: Any = 1) -> Any:
    """Make the vectorized env the config names; env errors come back naming the file.

    ``runners=True`` (the training envs) honours ``vecenv_type: RAY`` / ``env_runners`` (Ray workers);
    play, evaluation and export build the same envs in this process (RAY -> auto). ``groups``: env groups
    stepping in the background (PPO's ``env_groups``; the algorithm that pipelines its rollout passes it).
    """
    cfg = params.config
    merged = dict(cfg.env_config)
    merged.update(env_config or {})
    vecenv_type, env_runners = cfg.vecenv_type, cfg.env_runners if runners else None
    if not runners and str(vecenv_type).lower() == "ray":
        vecenv_type = None
    try:
        env = make_vec_env(cfg.env_name, merged, num_envs, seed, vecenv_type, render=render,
                           env_runners=env_runners, groups=groups)
        return keep_keys_apart(env) if takes_dict_obs(params) else env
    except ValueError as exc:
        raise ConfigError(params.source, "", str(exc)) from None


def takes_dict_obs(params: Params) -> bool:
    """Whether the config's network takes Dict observations per key (its builder's ``takes_dict_obs``)."""
    name = network_name(params.network)
    return name in NETWORKS and bool(getattr(NETWORKS.get(name), "takes_dict_obs", False))


def keep_keys_apart(env: Any) -> Any:
    """``env``, its Dict observations split back per key when a backend flattened them (``PerKeyObs``). A backend
    whose observations have keys only on request (mjlab's observation groups) lays them out per key first
    through its ``keep_keys_apart()``."""
    if callable(getattr(type(env), "keep_keys_apart", None)):
        env = env.keep_keys_apart()
    if isinstance(getattr(env, "observation_space", None), FlatDictBox):
        return attach_spec(per_key_obs(env))
    return env
