"""rl_games-style env registration: ``env_configurations.register(name, {'env_creator': ...})``.

``env_creator(**env_config)`` returns one gymnasium env; it is registered with gymnasium under
``name`` so every gymnasium backend (sync, async) vectorizes it. A ``vecenv_creator``
``(num_envs, seed, **env_config) -> VecEnv`` registers a natively batched env instead. The entry is
kept in :data:`configurations` (rl_games' name); its ``vecenv_type`` selects the vector env
(``rlchain.envs.vecenv.register``) when the YAML names none, as in rl_games: how Isaac Lab plugs in.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from rlchain.registry import ENV_CONFIGURATIONS, ENVS

configurations = ENV_CONFIGURATIONS
"""rl_games' ``env_configurations.configurations``: name -> the dict given to :func:`register`."""


def register(name: str, config: dict[str, Any], overwrite: bool = False) -> None:
    """Register an env under ``name`` for ``params.config.env_name``."""
    if "vecenv_creator" in config:
        ENVS.register(name, config["vecenv_creator"], overwrite=overwrite)
        ENV_CONFIGURATIONS[name] = config
        return
    if "env_creator" not in config:
        raise ValueError(f"env '{name}': config needs 'env_creator' or 'vecenv_creator'")
    if name in gym.registry and not overwrite:
        raise ValueError(f"env '{name}' is already registered; pass overwrite=True to replace it")
    creator = config["env_creator"]
    gym.register(id=name, entry_point=lambda **kwargs: creator(**kwargs),
                 max_episode_steps=config.get("max_episode_steps"))
    ENV_CONFIGURATIONS[name] = config
