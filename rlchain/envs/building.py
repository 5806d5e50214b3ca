"""Turn an ``env_name`` / ``env_config`` / ``vecenv_type`` into a VecEnv in this process.

This is the env building that :mod:`rlchain.envs.factory` (the entry point, which adds Ray env
runners and the :class:`~rlchain.envs.spec.EnvSpec`) and each Ray env worker
(:mod:`rlchain.envs.ray.ray_worker`) share, so neither imports the other.

``env_name`` is resolved in this order:

1. a name registered with :func:`rlchain.env_configurations.register` (:data:`rlchain.registry.ENVS`) whose
   entry has a ``vecenv_creator`` ``(num_envs, seed, **env_config) -> VecEnv`` (it also gets
   ``vecenv_type=`` / ``render=`` / ``groups=`` when its signature names them). Built in:
   ``openai_gym`` and ``ray`` (gymnasium id in ``env_config.name``; ``vecenv_type: RAY`` puts ``ray``'s on Ray
   workers, as any env's), ``gymnasium`` (rl_games 2.0: gymnasium id in
   ``env_config.env_name``), ``envpool`` (task id in
   ``env_config.env_name``), ``brax`` (a brax.envs name in ``env_config.env_name``, a tensor env),
   ``playground`` (a MuJoCo Playground registry name in ``env_config.env_name``, a tensor env)
   and ``pettingzoo``;
2. a gymnasium id, ``env_config`` being ``gym.make`` keyword arguments (an entry with an ``env_creator`` is
   registered with gymnasium under its name).

``vecenv_type`` is looked up in :data:`rlchain.registry.VECENVS` (:func:`rlchain.envs.vecenv.register`):
the built-in names (``rlchain.envs.factory.BuiltinVecEnv``, registered in :mod:`rlchain.builtins`) carry a
``builtin_mode`` handled here; any other name is a user's rl_games-style creator
(:mod:`rlchain.envs.backends.rl_games_vecenv`).
Config mistakes raise :class:`ConfigError` (a ValueError) naming the key path; the caller adds
the file name.
"""

from __future__ import annotations

import inspect
import re
from typing import Any

import gymnasium as gym

from rlchain.config.errors import ConfigError
from rlchain.envs.backends.atari import atari_gym_env
from rlchain.envs.backends.brax_env import brax_env
from rlchain.envs.backends.envpool_env import EnvpoolVecEnv, envpool_config_keys, envpool_tasks
from rlchain.envs.backends.gymnasium_env import GymnasiumVecEnv, native_vector_class
from rlchain.envs.backends.pettingzoo_env import pettingzoo_env
from rlchain.envs.backends.playground_env import playground_env
from rlchain.envs.backends.rl_games_vecenv import make_registered_vecenv
from rlchain.envs.vecenv import VecEnv, resolve_vecenv_type
from rlchain.envs.wrappers.multi_agent import make_multi_agent_env
from rlchain.envs.wrappers.reward_action_obs import RewardActionObs
from rlchain.errors import did_you_mean
from rlchain.registry import ENVS

VECENV_TYPES = ("auto", "sync", "async", "native", "envpool", "ray")
RL_GAMES_ENVPOOL_KEYS = {"has_lives", "flatten_obs", "env_type"}
"""rl_games envpool env_config keys that are not envpool.make arguments; accepted and not used
(has_lives: Atari scores are always whole games, from envpool's own game-over signal, see
envpool_env.game_signals; Dict obs are always flattened; the gymnasium API is always used).
``use_dict_obs_space: True`` adds the previous reward and action to the obs (envs/wrappers/reward_action_obs.py)."""

NAME, CONFIG, VECENV = "params.config.env_name", "params.config.env_config", "params.config.vecenv_type"
GROUPS = "params.config.env_groups"


def resolve_env_groups(groups: Any, num_envs: int) -> int:
    """``env_groups`` for an envpool backend of ``num_envs`` envs: ``auto`` -> 2 when ``num_envs`` is
    even and >= 16 (the PPO trainer then measures whether one pool is faster: algos/ppo/env_layout.py),
    else 1; an int must divide ``num_envs``."""
    if groups == "auto":
        return 2 if num_envs >= 16 and num_envs % 2 == 0 else 1
    if num_envs % int(groups):
        raise _error(GROUPS, f"{groups} does not divide num_actors {num_envs}")
    return int(groups)


def _no_groups(groups: Any, what: str) -> None:
    """An explicit ``env_groups`` > 1 for a backend that steps synchronously: one-line error."""
    if groups != "auto" and int(groups) > 1:
        raise _error(GROUPS, f"{groups} needs an envpool env (env_name envpool or vecenv_type envpool); "
                             f"{what} steps all envs together (use 1 or auto)")


def _error(path: str, message: str) -> ConfigError:
    return ConfigError("", path, message)


def normalize_vecenv_type(vecenv_type: str | None, env_name: str | None = None) -> str:
    """The built-in mode (one of :data:`VECENV_TYPES`) or the user-registered name ``vecenv_type``
    selects (see :func:`rlchain.envs.vecenv.resolve_vecenv_type`); ConfigError for unknown names."""
    name, creator = resolve_vecenv_type(vecenv_type, env_name)
    return getattr(creator, "builtin_mode", name)


def build_local_env(env_name: str, env_config: dict | None, num_envs: int, seed: int | None,
                    vecenv_type: str | None, render: bool = False, groups: Any = 1) -> VecEnv:
    """Build ``num_envs`` envs named ``env_name`` in this process (see the module docstring), seeded
    from ``seed``: what :func:`rlchain.envs.factory.make_vec_env` does without Ray, and what each Ray
    env worker runs for its slice.

    ``env_config.seed``, when present, replaces ``seed`` (rl_games envpool configs). ``render=True``
    asks for ``render_mode='human'`` (the Player). ``groups`` (``env_groups``: auto or an int) splits
    envpool envs into groups that step in the background; other backends take only 1 or auto.
    """
    kind = normalize_vecenv_type(vecenv_type, env_name)
    if kind == "ray":
        raise _error(VECENV, "RAY builds its envs on Ray workers (rlchain.envs.factory.make_vec_env), "
                             "not in this process")
    config = dict(env_config or {})
    seed = config.pop("seed", seed)  # rl_games configs seed envpool through env_config.seed
    for key in ("num_envs", "vecenv_type", "render"):
        if key in config:
            raise _error(f"{CONFIG}.{key}", "is set by rlchain (num_actors, vecenv_type, player.render)")
    if not env_name:
        raise _error(NAME, "is empty; give a gymnasium id, openai_gym, envpool or a registered env")
    if kind not in VECENV_TYPES:  # a user-registered vecenv_type
        _no_groups(groups, f"vecenv_type '{kind}'")
        return make_registered_vecenv(resolve_vecenv_type(kind)[1], env_name, num_envs, seed, render, config)
    builder = ENVS.get(env_name).get("vecenv_creator") if env_name in ENVS else None
    if builder is not None:
        params = inspect.signature(builder).parameters
        extra = {k: v for k, v in (("vecenv_type", kind), ("render", render), ("groups", groups))
                 if k in params}
        if "groups" not in params:
            _no_groups(groups, f"env '{env_name}'")
        return builder(num_envs, seed, **extra, **config)
    return _gym_id_env(env_name, NAME, config, num_envs, seed, kind, render, groups)


def openai_gym_env(num_envs: int, seed: int | None, *, vecenv_type: str | None = None,
                   render: bool = False, groups: Any = 1, **env_config: Any) -> VecEnv:
    """``env_name: openai_gym``: the gymnasium id is ``env_config.name``, the rest gym.make kwargs."""
    if "name" not in env_config:
        raise _error(f"{CONFIG}.name", "is required with env_name openai_gym or ray (a gymnasium id)")
    name = env_config.pop("name")
    return _gym_id_env(name, f"{CONFIG}.name", env_config, num_envs, seed,
                       normalize_vecenv_type(vecenv_type), render, groups)


GYMNASIUM_KEYS = {"flatten_obs"}
"""rl_games 2.0 ``env_name: gymnasium`` env_config keys that are not gym.make arguments and need nothing here
(flatten_obs: rlchain flattens Dict observations anyway)."""


def gymnasium_vecenv_kind(env_config: dict[str, Any], vecenv_type: str | None) -> str:
    """rl_games 2.0's GymnasiumVecEnv options, popped from ``env_config``: ``use_async`` (default True, as in
    rl_games) picks async or sync when ``vecenv_type`` is unset (auto); ``wrap_env`` / ``env_creator`` are
    Python callables, an error. Returns the vecenv kind."""
    use_async = env_config.pop("use_async", True)
    if not isinstance(use_async, bool):
        raise _error(f"{CONFIG}.use_async", f"expected true or false, got {use_async!r}")
    if env_config.pop("wrap_env", None) is not None or env_config.pop("env_creator", None) is not None:
        raise _error(CONFIG, "wrap_env / env_creator are Python callables of rl_games' GymnasiumVecEnv; register "
                             "the env with env_configurations.register instead")
    kind = normalize_vecenv_type(vecenv_type)
    return ("async" if use_async else "sync") if kind == "auto" else kind


def gymnasium_env(num_envs: int, seed: int | None, *, vecenv_type: str | None = None,
                  render: bool = False, groups: Any = 1, **env_config: Any) -> VecEnv:
    """``env_name: gymnasium`` (rl_games 2.0): the gymnasium id is ``env_config.env_name`` (MuJoCo's ``-v5``
    names, dm_control's ``dm_control/...``); ``use_async`` (default True, as in rl_games) picks the async
    backend, False the sync one, when ``vecenv_type`` is unset; the other keys go to ``gym.make``."""
    if "env_name" not in env_config:
        raise _error(f"{CONFIG}.env_name", "is required with env_name gymnasium (a gymnasium id)")
    name = env_config.pop("env_name")
    kind = gymnasium_vecenv_kind(env_config, vecenv_type)
    for key in GYMNASIUM_KEYS:
        env_config.pop(key, None)
    return _gym_id_env(name, f"{CONFIG}.env_name", env_config, num_envs, seed, kind, render, groups)


def atari_gymnasium_env(num_envs: int, seed: int | None, *, vecenv_type: str | None = None,
                        render: bool = False, **env_config: Any) -> VecEnv:
    """``env_name: atari_gymnasium`` (rl_games 2.0): the ALE id is ``env_config.env_name`` (``ALE/Pong-v5``),
    with 2.0's preprocessing: noop reset, frame skip 4, 84x84 grayscale, a life loss ends the training episode,
    no FIRE reset, 4 frames stacked channels first (its configs read them with ``permute_input: False``), the
    id's own sticky actions. ``frameskip`` (2.0 passes 1 to ``gym.make``) must stay 1: the wrapper skips.
    ``use_async`` (default True, as in rl_games) picks the async backend, False the sync one, when
    ``vecenv_type`` is unset."""
    if "env_name" not in env_config:
        raise _error(f"{CONFIG}.env_name", "is required with env_name atari_gymnasium (an ALE id: ALE/Pong-v5)")
    kind = gymnasium_vecenv_kind(env_config, vecenv_type)
    frameskip = env_config.pop("frameskip", 1)
    if frameskip != 1:
        raise _error(f"{CONFIG}.frameskip", f"expected 1 (the preprocessing skips 4 frames), got {frameskip!r}")
    options = {"name": env_config.pop("env_name"), "fire_reset": False, "channels_first": True, **env_config}
    return atari_gym_env(num_envs, seed, vecenv_type=kind, render=render, **options)


def envpool_env(num_envs: int, seed: int | None, *, vecenv_type: str | None = None,
                render: bool = False, groups: Any = 1, **env_config: Any) -> VecEnv:
    """``env_name: envpool``: task id ``env_config.env_name``, the other keys go to ``envpool.make``."""
    if normalize_vecenv_type(vecenv_type) not in ("auto", "envpool"):
        raise _error(VECENV, f"'{vecenv_type}' does not apply to env_name envpool; leave it unset")
    if "env_name" not in env_config:
        raise _error(f"{CONFIG}.env_name", "is required with env_name envpool (an envpool task id)")
    task = env_config.pop("env_name")
    return _envpool(task, f"{CONFIG}.env_name", env_config, num_envs, seed, render, groups)


def _envpool(task: str, path: str, kwargs: dict, num_envs: int, seed: int | None,
             render: bool, groups: Any = 1) -> VecEnv:
    """Check ``task`` and ``kwargs`` against envpool, then build the envpool backend."""
    tasks = envpool_tasks()
    if task not in tasks:
        raise _error(path, f"envpool has no task '{task}'{did_you_mean(task, tasks)}")
    dict_obs = kwargs.pop("use_dict_obs_space", False)  # rl_games: previous reward and action in the obs
    repeat = kwargs.pop("action_repeat", 1)  # rlchain's own (envs/wrappers/action_repeat.py), not an envpool option
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise _error(f"{CONFIG}.action_repeat", f"expected an integer >= 1 (env steps per action), got {repeat!r}")
    for key in RL_GAMES_ENVPOOL_KEYS:
        kwargs.pop(key, None)
    valid = envpool_config_keys(task)
    for key in kwargs:
        if key not in valid:
            raise _error(f"{CONFIG}.{key}", f"not an envpool option of '{task}'"
                         f"{did_you_mean(key, valid)} (valid: {', '.join(sorted(valid))})")
    groups = resolve_env_groups(groups, num_envs)
    extra = {"groups": groups} if groups > 1 else {}  # a user-registered backend may not take groups
    if repeat > 1:
        extra["action_repeat"] = repeat
    env = EnvpoolVecEnv(task, num_envs, seed=seed, env_kwargs=kwargs, render=render, **extra)
    if dict_obs:
        try:
            env = RewardActionObs(env, f"{CONFIG}.use_dict_obs_space")
        except ConfigError:
            env.close()
            raise
    return env


def _gym_id_env(name: str, path: str, kwargs: dict, num_envs: int, seed: int | None, kind: str,
                render: bool, groups: Any = 1) -> VecEnv:
    """Build a gymnasium id with backend ``kind`` (auto/sync/async/native/envpool)."""
    if kind == "envpool":
        if name not in envpool_tasks():  # ImportError with the install hint when it is missing
            hint = did_you_mean(name, envpool_tasks())
            raise _error(VECENV, f"envpool has no task '{name}' (from {path}){hint}")
        return _envpool(name, path, kwargs, num_envs, seed, render, groups)
    _no_groups(groups, f"the gymnasium '{kind}' backend")
    if not _gym_knows(name):
        try:
            in_envpool = name in envpool_tasks()
        except ImportError:
            in_envpool = False
        hint = ("; envpool has it: set params.config.vecenv_type: envpool" if in_envpool
                else did_you_mean(name, list(gym.registry) + ENVS.names()))
        raise _error(path, f"unknown environment '{name}'{hint} "
                           f"(a gymnasium id, or a registered env: {', '.join(ENVS.names())})")
    if kind == "native" and (render or native_vector_class(name, kwargs) is None):
        why = "rendering needs sync" if render else "it has no native vector env taking these env_config keys"
        raise _error(VECENV, f"native is not available for '{name}': {why}; use auto, sync or async")
    try:
        multi = make_multi_agent_env(name, num_envs, kwargs, seed, kind, render)  # None: one agent per env
        if multi is not None:
            return multi
        return GymnasiumVecEnv(name, num_envs, mode=kind, env_kwargs=kwargs, render=render, seed=seed)
    except TypeError as exc:  # an env_config key the env constructor does not take
        key = re.search(r"keyword argument '(\w+)'", str(exc))
        raise _error(f"{CONFIG}.{key.group(1)}" if key else CONFIG, f"'{name}' rejects it: {exc}") from None


def _gym_knows(name: str) -> bool:
    """Whether gymnasium can make ``name`` (imports ``module:`` prefixes like gym.make does)."""
    try:
        gym.spec(name)
    except (gym.error.Error, ImportError):
        return False
    return True


BUILTIN_ENVS = {"openai_gym": openai_gym_env, "envpool": envpool_env, "gymnasium": gymnasium_env,
                "atari_gymnasium": atari_gymnasium_env,
                "ray": openai_gym_env,  # rl_games' `ray` entry: env_config.name; vecenv_type RAY -> Ray workers
                "brax": brax_env,  # imports jax/brax only when built
                "playground": playground_env,  # imports mujoco_playground only when built
                "pettingzoo": pettingzoo_env}  # imports pettingzoo (and the env's package) only when built
"""The ``vecenv_creator`` of the envs :mod:`rlchain.builtins` registers with ``env_configurations.register``."""

VECENV_ALIASES = {"gymnasium": "auto", "brax": "auto"}
"""Other built-in ``vecenv_type`` names: rl_games' BRAX (the brax env is its own batch) and ``gymnasium``."""

__all__ = ["build_local_env", "resolve_env_groups", "normalize_vecenv_type", "openai_gym_env", "envpool_env",
           "gymnasium_env",
           "VECENV_TYPES", "BUILTIN_ENVS", "VECENV_ALIASES"]
