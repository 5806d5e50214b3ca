"""EmbodiChain's env contract as an rlchain backend: any batched torch env with

- ``num_envs``, ``device``, single-env spaces (``single_observation_space`` / ``single_action_space``, or
  ``observation_space`` / ``action_space``);
- ``reset(seed=None) -> (obs, info)`` and ``step(actions) -> (obs, reward, terminated, truncated, info)``,
  every tensor batched (N, ...) on ``device``; finished rows reset in the same step, and no final
  observation is given (``obs`` of a finished row is already the next episode's first);
- ``obs`` a tensor or a (nested) dict of tensors, flattened in sorted-key order as EmbodiChain does (a dict's
  keys stay named, ``robot/qpos`` for a nested one: a ``multi_input`` network gets them apart again, an image
  as uint8, through ``PerKeyObs``);
- ``info`` with optional ``success`` / ``fail`` (N,) bool, ``elapsed_steps``, ``metrics`` {name: (N,)} and
  ``rewards`` {term: (N,)} (each reward term unweighted).

:func:`register_env` registers a class or factory ``(num_envs=, device=, **cfg) -> env`` under a name (a
decorator, as EmbodiChain's ``register_learning_env``); the name is then an rlchain env
(``params.config.env_name``, or ``trainer.gym_config`` / ``trainer.learning_env`` of an EmbodiChain
config). :class:`EmbodiChainVecEnv` adapts such an env to rlchain's VecEnv contract
(:mod:`rlchain.envs.vecenv`); ``info`` passes through, so ``success`` is rlchain's success key and the
``rewards`` / ``metrics`` dicts reach TensorBoard (rlchain.training.embodichain_tags). Where the env has
``get_state`` / ``set_state`` they pass through too (exact resume, GRPO's shared starts).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.tensor_env import resolve_env_device
from rlchain.envs.vecenv import StepResult, close_env
from rlchain.envs.wrappers.dict_obs import FlatDictBox
from rlchain.registry import ENVS

CONFIG = "params.config.env_config"


def flatten_obs(obs: Any) -> torch.Tensor:
    """A tensor, or a nested dict of (N, ...) tensors flattened to (N, D) in sorted-key order."""
    if isinstance(obs, torch.Tensor):
        return obs.reshape(obs.shape[0], -1) if obs.dim() != 2 else obs
    if isinstance(obs, dict):
        parts = [flatten_obs(obs[key]) for key in sorted(obs)]
        return torch.cat([p.float() for p in parts], dim=-1)
    raise TypeError(f"observation of type {type(obs).__name__}: expected a tensor or a dict of tensors")


def dict_space_of(obs: dict, prefix: str = "") -> list[tuple[str, gym.spaces.Box]]:
    """The (key, Box) entries of a nested dict observation in :func:`flatten_obs`'s order, a nested key's name its
    path joined by ``/`` (``robot/qpos``); a Box of one row's shape, uint8 (0..255) for a uint8 tensor, float32
    otherwise: the layout of a :class:`~rlchain.envs.wrappers.dict_obs.FlatDictBox`."""
    entries: list[tuple[str, gym.spaces.Box]] = []
    for key in sorted(obs):
        value, name = obs[key], f"{prefix}{key}"
        if isinstance(value, dict):
            entries += dict_space_of(value, f"{name}/")
        elif value.dtype == torch.uint8:
            entries.append((name, gym.spaces.Box(0, 255, tuple(value.shape[1:]), np.uint8)))
        else:
            entries.append((name, gym.spaces.Box(-np.inf, np.inf, tuple(value.shape[1:]), np.float32)))
    return entries


class EmbodiChainVecEnv:
    """An EmbodiChain-contract env as rlchain's tensor VecEnv (see the module docstring)."""

    is_tensor_env = True
    steps_on_torch_threads = True

    def __init__(self, env: Any, name: str) -> None:
        self.env, self.name = env, name
        self.num_envs = int(env.num_envs)
        self.device = torch.device(getattr(env, "device", "cpu"))
        self.action_space = getattr(env, "single_action_space", None) or env.action_space
        self.observation_space: gym.spaces.Box | None = None
        space = getattr(env, "single_observation_space", None) or getattr(env, "observation_space", None)
        if isinstance(space, gym.spaces.Box) and len(space.shape) == 1:
            self.observation_space = gym.spaces.Box(-np.inf, np.inf, space.shape, np.float32)
        self._obs: torch.Tensor | None = None

    def _flat(self, obs: Any) -> torch.Tensor:
        flat = flatten_obs(obs).float()
        if self.observation_space is None:  # a dict space: its keys and shapes from the first observation
            self.observation_space = (FlatDictBox(gym.spaces.Dict(dict_space_of(obs)), np.float32)
                                      if isinstance(obs, dict)
                                      else gym.spaces.Box(-np.inf, np.inf, (flat.shape[-1],), np.float32))
        return flat

    def describe_shapes(self) -> None:
        """Learn the flat observation size from one reset when the env's space is a dict."""
        if self.observation_space is None:
            self.reset()

    def reset(self, seed: int | None = None) -> torch.Tensor:
        """Reset every env (``seed``: reseed it); returns the flat first observations (N, D)."""
        obs, _ = self.env.reset(seed=seed)
        self._obs = self._flat(obs)
        return self._obs

    def step(self, actions: Any) -> StepResult:
        """One step of the batch; ``final_obs`` is the next observation (the contract gives no final one)."""
        if not isinstance(actions, torch.Tensor):
            actions = torch.as_tensor(np.asarray(actions), device=self.device)
        obs, reward, terminated, truncated, info = self.env.step(actions.to(self.device))
        obs = self._flat(obs)
        terminated, truncated = _flags(terminated, self.num_envs), _flags(truncated, self.num_envs)
        self._obs = obs
        return StepResult(obs, reward.reshape(-1).float(), terminated, truncated, obs,
                          info if isinstance(info, dict) else {})

    def close(self) -> None:
        close_env(self.env)

    def seed(self, seed: int) -> None:
        self.env.reset(seed=seed)

    def __getattr__(self, name: str) -> Any:
        # get_state / set_state / detach_state and the like, where the env has them
        if name in ("get_state", "set_state", "detach_state", "share_group_starts"):
            return getattr(self.__dict__["env"], name)
        raise AttributeError(name)


def _flags(x: Any, n: int) -> torch.Tensor:
    return torch.as_tensor(x).reshape(n).bool()


def contract_builder(name: str, target: Callable[..., Any]) -> Callable[..., EmbodiChainVecEnv]:
    """The :data:`rlchain.registry.ENVS` builder ``(num_envs, seed, device='cpu', render=False, **cfg)`` of an
    EmbodiChain-contract env class or factory ``target(num_envs=, device=, **cfg)``: ``cfg`` (``env_config`` /
    EmbodiChain's ``learning_env.cfg``) goes to it; a key it does not take is an error naming it."""
    params = inspect.signature(target).parameters
    open_kwargs = any(p.kind is p.VAR_KEYWORD for p in params.values())
    accepted = [p for p in params if p not in ("self", "num_envs", "device")]

    def build(num_envs: int, seed: int | None, device: str = "cpu", render: bool = False,
              **cfg: Any) -> EmbodiChainVecEnv:
        if render:
            raise ValueError(f"params.config.player.render: {name} is a tensor env and does not render")
        if not open_kwargs:
            for key in cfg:
                if key not in accepted:
                    raise ValueError(f"{CONFIG}.{key}: not an option of {name} (valid: device, "
                                     f"{', '.join(accepted)})")
        env = EmbodiChainVecEnv(target(num_envs=num_envs, device=resolve_env_device(device), **cfg), name)
        if seed is not None:
            env.env.reset(seed=seed)
        env.describe_shapes()
        return env

    build.__name__ = build.__qualname__ = f"build_{name}"
    build.__doc__ = f"Builder of the EmbodiChain-contract env ``{name}`` ({getattr(target, '__name__', '?')})."
    return build


def register_env(name: str, factory: Callable[..., Any] | None = None, *, overwrite: bool = False) -> Any:
    """Register an EmbodiChain-contract env class or factory under ``name`` (a decorator, or a direct call, as
    EmbodiChain's ``register_learning_env``): the entry ``{'vecenv_creator': contract_builder(name, target)}``
    that ``env_configurations.register`` makes (see :func:`contract_builder`)."""

    def decorator(target: Callable[..., Any]) -> Callable[..., Any]:
        ENVS.register(name, {"vecenv_creator": contract_builder(name, target)}, overwrite=overwrite)
        return target

    return decorator if factory is None else decorator(factory)


__all__ = ["EmbodiChainVecEnv", "contract_builder", "dict_space_of", "flatten_obs", "register_env"]
