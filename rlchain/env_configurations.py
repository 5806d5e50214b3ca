"""rl_games-style env registration: ``env_configurations.register(name, {'env_creator': ...})``.

``env_creator(**env_config)`` returns a single gymnasium env; rlchain vectorizes it with
gymnasium's sync vector env (``vecenv_type: async`` for subprocesses). A ``vecenv_creator``
``(num_envs, seed, **env_config) -> VecEnv`` may be given instead for natively batched envs.
"""

from __future__ import annotations

from typing import Any

from rlchain.registry import ENVS


def register(name: str, config: dict[str, Any], overwrite: bool = False) -> None:
    """Register an env under ``name`` for ``params.config.env_name``."""
    if "env_creator" not in config and "vecenv_creator" not in config:
        raise ValueError(f"env '{name}': config needs 'env_creator' or 'vecenv_creator'")
    ENVS.register(name, config, overwrite=overwrite)
