"""The worker side of the Ray env runners (:mod:`rlchain.envs.ray.ray_env`): what runs inside an actor.

:class:`EnvRecipe` travels to the actor and builds its slice of envs there; :class:`EnvWorker` is
the actor's body (made a Ray actor by ``ray.remote`` in ray_env.py, so this module needs no ray).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import pickle
import re
import sys
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.envs.building import build_local_env
from rlchain.envs.spec import attach_spec, env_spec
from rlchain.registry import ENVS, VECENVS, Deferred, skip_builtins


@dataclass
class EnvRecipe:
    """How a worker builds its envs: the config's env plus the registrations this process made.

    Ray workers are fresh processes: envs registered in the learner at run time
    (``params.import_modules``, ``env_configurations.register``, ``gym.register``) travel along: every
    :data:`ENVS` and :data:`VECENVS` entry and every gymnasium spec whose entry point is a Python object (plus
    the specs of the named env), each one that cloudpickle can serialize. Pickled (to a worker), each
    :data:`ENVS` / :data:`VECENVS` entry travels on its own and is unpickled on its first lookup there, and a
    gymnasium entry point that a module names travels as that name (``module:Name``, which gymnasium imports
    when it makes the env), so a worker imports the modules of the env it builds, not those of every registered
    env (torch's tensor envs, a test module).
    """

    env_name: str
    env_config: dict
    vecenv_type: str
    builders: dict = field(default_factory=dict)
    gym_specs: dict = field(default_factory=dict)
    vecenvs: dict = field(default_factory=dict)
    """The learner's :data:`VECENVS` (``vecenv_type`` name -> creator), built-ins included."""
    success_key: str = "auto"
    """The info key an APPO runner reads task success from (``params.config.success_key``)."""
    log_info_keys: tuple = ()
    """The info keys an APPO runner averages for TensorBoard (``params.config.log_info_keys``)."""

    @classmethod
    def capture(cls, env_name: str, env_config: dict | None, vecenv_type: str) -> EnvRecipe:
        config = dict(env_config or {})
        named = {env_name, config.get("name")}
        specs = {k: s for k, s in gym.registry.items() if k in named or callable(s.entry_point)}
        builders = {name: ENVS.get(name) for name in ENVS.names()}
        vecenvs = {name: VECENVS.get(name) for name in VECENVS.names()}
        return cls(env_name, config, vecenv_type, _picklable(builders), _picklable(specs),
                   vecenvs=_picklable(vecenvs))

    def __getstate__(self) -> dict:
        """What pickling sends: the registry entries each as its own pickle, unpickled on first lookup."""
        state = dict(self.__dict__)
        for key in ("builders", "vecenvs"):
            state[key] = {name: _deferred(entry) for name, entry in state[key].items()}
        state["gym_specs"] = {name: _entry_point_by_name(spec) for name, spec in state["gym_specs"].items()}
        return state

    def build(self, num_envs: int, seed: int | None) -> Any:
        """The VecEnv of ``num_envs`` envs (runs inside the worker)."""
        for name, spec in self.gym_specs.items():
            gym.registry.setdefault(name, spec)
        for name, entry in self.builders.items():  # the learner's tables as they were (gym specs copied above)
            ENVS.register(name, entry, overwrite=True)
        for name, creator in self.vecenvs.items():
            VECENVS.register(name, creator, overwrite=True)
        env = attach_spec(build_local_env(self.env_name, dict(self.env_config), num_envs, seed, self.vecenv_type))
        problem = _unsupported(env)
        if problem:
            env.close()
            raise ValueError(f"params.config.env_name: '{self.env_name}' {problem}; Ray env workers do not "
                             f"support it: remove vecenv_type RAY / env_runners")
        return env


def _unsupported(env: Any) -> str | None:
    """What about ``env`` the Ray runners cannot carry (they move plain per-env numpy rows), or None."""
    spec = env_spec(env)
    if spec.tensor_native:
        return "is a tensor env (it lives on the training device)"
    if spec.num_agents > 1:
        return "has several agents per env"
    if spec.central_value:
        return "has central-value (dict) observations"
    if spec.action_masks:
        return "has action masks"
    return None


def per_env_infos(infos: Any, n: int) -> dict:
    """The step infos' per-env numbers: every value that is one number (or bool) per env, and the same of
    a gymnasium ``final_info`` dict. What the learner reads from infos (success, ``log_info_keys``) is
    of this kind; per-env vectors (final observations, frames) and objects stay in the worker."""
    if not isinstance(infos, dict):
        return {}
    out: dict = {}
    for key, value in infos.items():
        if key == "final_info" and isinstance(value, dict):
            final = per_env_infos(value, n)
            if final:
                out[key] = final
            continue
        if hasattr(value, "detach"):
            value = value.detach().cpu().numpy()
        if isinstance(value, np.ndarray) and value.shape == (n,) and (value.dtype.kind in "biuf"):
            out[str(key)] = value
    return out


def _deferred(entry: Any) -> Deferred:
    """``entry`` as a registry entry unpickled on its first lookup (where it is unpickled, its module is imported)."""
    import cloudpickle

    return entry if isinstance(entry, Deferred) else Deferred(functools.partial(pickle.loads, cloudpickle.dumps(entry)))


def _entry_point_by_name(spec: Any) -> Any:
    """``spec`` with its entry point as gymnasium's ``module:Name`` string when that names the same object (a
    class or function at the top of an imported module), else (a lambda, a nested class) as a
    :class:`LazyEntryPoint`: either way the worker imports the entry point's module only when it makes that env."""
    entry = spec.entry_point
    if not callable(entry):
        return spec
    module, name = getattr(entry, "__module__", None), getattr(entry, "__qualname__", "")
    if module and module != "__main__" and "." not in name and "<" not in name \
            and getattr(sys.modules.get(module), name, None) is entry:
        return dataclasses.replace(spec, entry_point=f"{module}:{name}")
    import cloudpickle

    return dataclasses.replace(spec, entry_point=LazyEntryPoint(cloudpickle.dumps(entry)))


class LazyEntryPoint:
    """A gymnasium entry point sent as cloudpickle's bytes and unpickled at its first use (a call, or gymnasium's
    ``make`` reading its ``metadata``), so a worker that never makes that env never imports the module it was
    defined in."""

    def __init__(self, blob: bytes) -> None:
        self._blob, self._entry = blob, None

    def _load(self) -> Any:
        if self._entry is None:
            self._entry = pickle.loads(self._blob)
        return self._entry

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self._load()(*args, **kwargs)

    @property
    def metadata(self) -> dict:
        """The entry point's ``metadata`` (gymnasium's ``make`` reads its render modes from it); AttributeError, so
        ``hasattr`` is False, where the entry point has none (a lambda)."""
        entry = self._load()
        if not hasattr(entry, "metadata"):
            raise AttributeError("metadata")
        return entry.metadata

    def __getstate__(self) -> dict:
        return {"_blob": self._blob, "_entry": None}


def _picklable(items: dict) -> dict:
    """The entries cloudpickle (what Ray uses) can serialize; the others stay behind."""
    import cloudpickle

    out = {}
    for key, value in items.items():
        try:
            cloudpickle.dumps(value)
        except Exception:
            continue
        out[key] = value
    return out


class EnvWorker:
    """The body of one Ray actor: envs ``[start, start + num_envs)`` of the batch, arrays in and out.

    ``own_process`` (what :class:`~rlchain.envs.ray.ray_env.RayVecEnv` gives its actors): this process's registries
    are the recipe's tables; rlchain's built-ins (every algorithm, torch) are never loaded here."""

    def __init__(self, recipe: EnvRecipe, start: int, num_envs: int, own_process: bool = False) -> None:
        if own_process:
            skip_builtins()
        self.recipe, self.start, self.num_envs, self.env = recipe, start, num_envs, None

    def build(self, seed: int | None) -> dict:
        """Make the envs; returns what the learner needs to know about them (spaces, value_size)."""
        try:
            self.env = self.recipe.build(self.num_envs, seed)
        except ValueError as exc:  # config errors travel as plain ValueErrors (picklable, one line)
            raise ValueError(str(exc)) from None
        return {"observation_space": self.env.observation_space, "action_space": self.env.action_space,
                "value_size": env_spec(self.env).value_size}

    def pid(self) -> int:
        return os.getpid()

    def reset(self, seed: int | None) -> np.ndarray:
        return self._global(lambda: np.asarray(self.env.reset(seed=seed)))

    def step(self, actions: bytes) -> bytes:
        """Pickled actions (n, *action_shape) -> the pickled tuple (obs, reward, terminated, truncated,
        ended rows, their final obs, game_reward, game_over, the infos' per-env numbers).

        One pickled bytes object each way: Ray serializes it faster than a tuple of numpy arrays.
        """
        r = self._global(lambda: self.env.step(pickle.loads(actions)))
        rows = np.flatnonzero(np.asarray(r.terminated) | np.asarray(r.truncated))
        final = np.asarray(r.final_obs)[rows]
        extra = [None if x is None else np.asarray(x) for x in (r.game_reward, r.game_over)]
        return pickle.dumps((np.asarray(r.obs), np.asarray(r.reward), np.asarray(r.terminated),
                             np.asarray(r.truncated), rows, final, *extra, per_env_infos(r.infos, self.num_envs)),
                            protocol=pickle.HIGHEST_PROTOCOL)

    def close(self) -> None:
        if self.env is not None:
            self.env.close()

    def _global(self, fn: Any) -> Any:
        """Run ``fn``; an env error is re-raised with the env's index in the whole batch."""
        try:
            return fn()
        except Exception as exc:
            text = " ".join(str(exc).split())
            text = re.sub(r"^env (\d+)", lambda m: f"env {self.start + int(m.group(1))}", text)
            raise RuntimeError(text if text.startswith("env ") else f"{type(exc).__name__}: {text}") from None
