"""The env door, rl_games': ``env_configurations.register(name, {'env_creator': ...})``.

``params.config.env_name`` looks a name up here first (then among gymnasium ids). An entry is a dict with

- ``env_creator(**env_config)`` -> one gymnasium env: it is also registered with gymnasium under ``name``, so
  every gymnasium backend (sync, async, Ray workers) vectorizes it;
- or ``vecenv_creator(num_envs, seed, **env_config)`` -> a VecEnv (:mod:`rlchain.envs.vecenv`): a natively
  batched env (it also gets ``vecenv_type=`` / ``render=`` / ``groups=`` when its signature names them);
- ``vecenv_type`` (optional, or alone): the vector env (``rlchain.envs.vecenv.register``, the other door) that
  builds the envs when the YAML names none, as in rl_games: how Isaac Lab plugs in.

rlchain's own envs (``openai_gym``, ``envpool``, ``brax``, the tensor envs, ...) are entries registered here
by :mod:`rlchain.builtins`. :data:`configurations` (rl_games' name) is the one table:
:data:`rlchain.registry.ENVS`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from rlchain.registry import ENVS

configurations = ENVS
"""rl_games' ``env_configurations.configurations``: name -> the dict given to :func:`register`."""

CREATOR_KEYS = ("env_creator", "vecenv_creator", "vecenv_type")


def register(name: str, config: dict[str, Any], overwrite: bool = False) -> None:
    """Make ``params.config.env_name: <name>`` build the env ``config`` describes (see the module docstring)."""
    if not isinstance(config, dict) or not any(key in config for key in CREATOR_KEYS):
        raise ValueError(f"env '{name}': config needs 'env_creator', 'vecenv_creator' or 'vecenv_type'")
    gym_env = "env_creator" in config and "vecenv_creator" not in config
    if gym_env and name in gym.registry and not overwrite:
        raise ValueError(f"env '{name}' is already registered; pass overwrite=True to replace it")
    ENVS.register(name, config, overwrite=overwrite)
    if gym_env:
        creator = config["env_creator"]
        gym.register(id=name, entry_point=lambda **kwargs: creator(**kwargs),
                     max_episode_steps=config.get("max_episode_steps"))
