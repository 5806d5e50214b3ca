"""The ``env`` argument of the SB3-style API as an ``env_name`` rlchain builds.

A gymnasium id is used as it is. A callable (``lambda: gym.make(...)``), a gymnasium env object or a
gymnasium ``SyncVectorEnv`` / ``AsyncVectorEnv`` object is registered with ``env_configurations.register``
under a fresh name whose builder steps those envs with rlchain's gymnasium backend. An env object is
one env (rlchain steps it, never closes it: it stays the caller's); a vector env object's sub-envs are
stepped by rlchain with same-step resets. A Stable-Baselines3 ``VecEnv`` (DummyVecEnv, SubprocVecEnv,
VecNormalize, ``make_vec_env``'s output) is stepped as it is, through
:class:`rlchain.envs.backends.sb3_vecenv.SB3VecEnv`, and stays the caller's (``model.get_env()`` returns it).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym

from rlchain import env_configurations
from rlchain.config.errors import ConfigError
from rlchain.envs.backends.gymnasium_env import GymnasiumVecEnv
from rlchain.envs.backends.sb3_vecenv import SB3VecEnv, is_sb3_vecenv, sb3_env_id

_COUNTER = itertools.count(1)


@dataclass(frozen=True)
class EnvSource:
    """What the config needs: ``env_name`` and, when the env argument fixes it, the env count."""

    env_name: str
    num_envs: int | None  # None: the caller picks (n_envs or the family's default)
    label: str  # the env in messages: 'CartPole-v1', 'a gymnasium env object (CartPole-v1)', ...
    vec_env: Any = None  # an SB3 VecEnv the caller passed (stepped as it is), else None


class _Borrowed(gym.Wrapper):
    """A caller's env object stepped by rlchain: closing the vector env leaves the object open."""

    def close(self) -> None:
        pass


def _id_of(env: Any) -> str:
    spec = getattr(env, "spec", None)
    return getattr(spec, "id", None) or type(getattr(env, "unwrapped", env)).__name__


def _register(label: str, factories: list[Callable[[], gym.Env]], fixed: bool) -> str:
    """A fresh env name whose builder steps ``factories`` (cycled when more envs are asked for, unless
    ``fixed``: env objects are exactly as many as given)."""
    name = f"python_env_{next(_COUNTER)}"

    def build(num_envs: int, seed: int | None, *, vecenv_type: str | None = None, render: bool = False,
              **env_config: Any) -> GymnasiumVecEnv:
        if env_config:
            raise ConfigError("", "params.config.env_config", f"{label} takes no env_config keys")
        if fixed and num_envs > len(factories):
            raise ConfigError("", "params.config.num_actors", f"{num_envs} envs asked of {label}, which is "
                                                              f"{len(factories)}; pass a callable for more envs")
        mode = "async" if str(vecenv_type).lower() == "async" else "sync"
        fns = [factories[i % len(factories)] for i in range(num_envs)]
        return GymnasiumVecEnv(name, num_envs, mode=mode, seed=seed, env_fns=fns)

    env_configurations.register(name, {"vecenv_creator": build})
    return name


def _register_sb3(label: str, venv: Any) -> str:
    """A fresh env name whose builder steps the SB3 vec env ``venv`` (exactly its ``num_envs``)."""
    name = f"python_env_{next(_COUNTER)}"

    def build(num_envs: int, seed: int | None, **env_config: Any) -> SB3VecEnv:
        if env_config:
            raise ConfigError("", "params.config.env_config", f"{label} takes no env_config keys")
        if num_envs != venv.num_envs:
            raise ConfigError("", "params.config.num_actors", f"{num_envs} envs asked of {label}, which is "
                                                              f"{venv.num_envs}")
        return SB3VecEnv(venv, seed=seed)

    env_configurations.register(name, {"vecenv_creator": build})
    return name


def env_source(env: Any, algo: str) -> EnvSource:
    """The :class:`EnvSource` of the SB3-style ``env`` argument (see the module docstring)."""
    if isinstance(env, str):
        return EnvSource(env, None, env)
    if is_sb3_vecenv(env):
        label = f"a Stable-Baselines3 {type(env).__name__} ({sb3_env_id(env)} x {env.num_envs})"
        return EnvSource(_register_sb3(label, env), int(env.num_envs), label, vec_env=env)
    if isinstance(env, gym.vector.SyncVectorEnv):
        label = f"a gymnasium SyncVectorEnv ({_id_of(env.envs[0])} x {env.num_envs})"
        objects = list(env.envs)
        return EnvSource(_register(label, [lambda e=e: _Borrowed(e) for e in objects], fixed=True),
                         len(objects), label)
    if isinstance(env, gym.vector.AsyncVectorEnv):
        label = f"a gymnasium AsyncVectorEnv (x {env.num_envs})"
        return EnvSource(_register(label, list(env.env_fns), fixed=False), env.num_envs, label)
    if isinstance(env, gym.vector.VectorEnv):
        raise ConfigError(f"rlchain.{algo.upper()}", "env", f"{type(env).__name__}: pass its gymnasium id, a "
                                                            f"callable that makes one env, or a SyncVectorEnv")
    if isinstance(env, gym.Env):
        label = f"a gymnasium env object ({_id_of(env)})"
        return EnvSource(_register(label, [lambda: _Borrowed(env)], fixed=True), 1, label)
    if callable(env):
        label = f"the env factory {getattr(env, '__name__', type(env).__name__)}"
        return EnvSource(_register(label, [env], fixed=False), None, label)
    raise ConfigError(f"rlchain.{algo.upper()}", "env", f"expected a gymnasium id, a gymnasium env or vector env, a "
                                                        f"Stable-Baselines3 VecEnv, or a callable that makes an env; "
                                                        f"got {type(env).__name__}")


def sb3_vec_env(env: Any, source: EnvSource, n_envs: int, seed: int | None) -> Any:
    """A Stable-Baselines3 ``VecEnv`` of the env argument ``env`` (what SB3's ``model.get_env()`` returns): the
    SB3 vec env itself when one was passed, else one SB3 builds as it would from that argument (``make_vec_env``
    for an id or a callable; an env object in a ``Monitor`` and a ``DummyVecEnv``; a gymnasium vector env's
    sub-envs or factories). Needs stable-baselines3 (imported here: it is optional)."""
    if source.vec_env is not None:
        return source.vec_env
    try:  # optional: stable-baselines3
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.monitor import Monitor
        from stable_baselines3.common.vec_env import DummyVecEnv
    except ImportError as exc:
        raise ModuleNotFoundError("model.get_env() returns a Stable-Baselines3 VecEnv: pip install "
                                  "stable-baselines3") from exc
    if isinstance(env, gym.vector.SyncVectorEnv):
        return DummyVecEnv([lambda e=e: Monitor(_Borrowed(e)) for e in env.envs])
    if isinstance(env, gym.vector.AsyncVectorEnv):
        return make_vec_env(env.env_fns[0], n_envs=env.num_envs, seed=seed)
    if isinstance(env, gym.Env):
        return DummyVecEnv([lambda: Monitor(_Borrowed(env))])
    return make_vec_env(env, n_envs=n_envs, seed=seed)


def same_spaces(a: Any, b: Any) -> bool:
    """Whether ``a`` and ``b`` (each with ``observation_space`` and ``action_space``) have the same kinds and
    shapes of spaces (bounds may differ in dtype; a flattened Dict's Box subclass is a Box)."""
    return all((isinstance(x, type(y)) or isinstance(y, type(x))) and x.shape == y.shape
               and getattr(x, "n", None) == getattr(y, "n", None)
               for x, y in ((a.observation_space, b.observation_space), (a.action_space, b.action_space)))
