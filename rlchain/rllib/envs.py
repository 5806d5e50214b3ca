"""RLlib's env argument as an env rlchain steps: a gymnasium id (``env_config`` as ``gym.make`` keywords, as
RLlib does), a name registered with ``ray.tune.registry.register_env`` (its creator gets an :class:`EnvContext`),
or an env class (built with an :class:`EnvContext`). Each becomes a fresh name registered with rlchain's
``env_configurations`` whose builder steps that many copies with rlchain's gymnasium backend; a ``MultiAgentEnv``
(class or creator) is stepped by the PettingZoo backend instead (:mod:`rlchain.rllib.multi_agent`)."""

from __future__ import annotations

import itertools
import sys
from collections.abc import Callable
from typing import Any

import gymnasium as gym

from rlchain import env_configurations
from rlchain.config.errors import ConfigError
from rlchain.envs.backends.gymnasium_env import GymnasiumVecEnv
from rlchain.errors import did_you_mean

_COUNTER = itertools.count(1)


class EnvContext(dict):
    """RLlib's ``EnvContext``: the ``env_config`` dict plus where this env copy runs."""

    def __init__(self, env_config: dict[str, Any] | None = None, worker_index: int = 0, vector_index: int = 0,
                 remote: bool = False, num_workers: int | None = None, recreated_worker: bool = False) -> None:
        super().__init__(env_config or {})
        self.worker_index = worker_index
        self.vector_index = vector_index
        self.remote = remote
        self.num_workers = num_workers or 0
        self.recreated_worker = recreated_worker

    def copy_with_overrides(self, env_config: dict[str, Any] | None = None, worker_index: int | None = None,
                            vector_index: int | None = None, remote: bool | None = None,
                            num_workers: int | None = None, recreated_worker: bool | None = None) -> EnvContext:
        return EnvContext(dict(self) if env_config is None else env_config,
                          self.worker_index if worker_index is None else worker_index,
                          self.vector_index if vector_index is None else vector_index,
                          self.remote if remote is None else remote,
                          self.num_workers if num_workers is None else num_workers,
                          self.recreated_worker if recreated_worker is None else recreated_worker)


def tune_registered(name: str) -> Callable[[Any], Any] | None:
    """The creator registered under ``name`` with Ray Tune's ``register_env`` (None: not registered, or no Ray).

    Only asked where a registration can exist: ``register_env`` was imported in this process, or Ray is running
    (a Tune trial or an actor reads the driver's registrations from Ray's store). Otherwise importing Ray Tune
    (several seconds of CPU) would only answer None."""
    ray = sys.modules.get("ray")
    if "ray.tune.registry" not in sys.modules and not (ray is not None and ray.is_initialized()):
        return None
    try:  # optional: ray
        from ray.tune.registry import ENV_CREATOR, _global_registry
    except ImportError:
        return None
    return _global_registry.get(ENV_CREATOR, name) if _global_registry.contains(ENV_CREATOR, name) else None


def env_maker(env: Any, env_config: dict[str, Any], runners: int, per_runner: int
              ) -> tuple[Callable[[int], gym.Env], str]:
    """(index -> a new env, a label). Env ``index`` runs on worker ``index // per_runner + 1`` (1-based, as RLlib's
    remote env runners; 0 with no runners) at vector index ``index % per_runner``."""
    def context(index: int) -> EnvContext:
        worker = index // per_runner + 1 if runners > 0 else 0
        return EnvContext(env_config, worker_index=worker, vector_index=index % per_runner, num_workers=runners)

    if isinstance(env, str):
        creator = tune_registered(env)
        if creator is not None:
            return flat(lambda index: creator(context(index))), f"the registered env '{env}'"
        if env not in gym.registry:
            raise ConfigError("AlgorithmConfig.environment()", "env", f"'{env}' is neither a gymnasium id nor a name "
                              f"registered with ray.tune.registry.register_env{did_you_mean(env, gym.registry)}")
        return flat(lambda index: gym.make(env, **env_config)), env
    if isinstance(env, type):  # a gym.Env or a MultiAgentEnv (rlchain.rllib.multi_agent) class
        return flat(lambda index: env(context(index))), f"the env class {env.__name__}"
    raise ConfigError("AlgorithmConfig.environment()", "env", f"expected a gymnasium id, a registered env name or an "
                      f"env class, got {type(env).__name__}")


ONE_HOT = (gym.spaces.Discrete, gym.spaces.MultiDiscrete)
"""Observation spaces a network cannot read as they are: one-hot, as RLlib's ``FlattenObservations`` connector
(which RLlib's examples with such envs add) and gymnasium's ``flatten`` give them."""


def flat(make: Callable[[int], gym.Env]) -> Callable[[int], gym.Env]:
    """``make`` whose envs with :data:`ONE_HOT` observations are wrapped in gymnasium's ``FlattenObservation``; the
    returned maker's ``flattened`` is True once it wrapped one (so the run steps the wrapped env, not the id)."""
    def build(index: int) -> gym.Env:
        env = make(index)
        multi_agent = any(c.__name__ == "MultiAgentEnv" for c in type(env).__mro__)  # its spaces are per agent
        if isinstance(env, gym.Env) and not multi_agent and isinstance(env.observation_space, ONE_HOT):
            build.flattened = True
            return gym.wrappers.FlattenObservation(env)
        return env

    build.flattened = False
    return build


def register(make: Callable[[int], gym.Env], label: str) -> str:
    """A fresh env name whose builder steps ``make(0..n-1)`` with rlchain's gymnasium backend."""
    name = f"rllib_env_{next(_COUNTER)}"

    def build(num_envs: int, seed: int | None, *, vecenv_type: str | None = None, render: bool = False,
              **env_config: Any) -> GymnasiumVecEnv:
        if env_config:
            raise ConfigError("", "params.config.env_config", f"{label} takes its env_config from the RLlib config")
        return GymnasiumVecEnv(name, num_envs, mode="sync", seed=seed,
                               env_fns=[lambda i=i: make(i) for i in range(num_envs)])

    env_configurations.register(name, {"vecenv_creator": build})
    return name
