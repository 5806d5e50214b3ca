"""rl_games' ``rl_games.common.vecenv``: ``register`` a vector-env creator, ``create_vec_env`` one.

``register(name, creator)`` fills rlchain's ``vecenv_type`` registry (:mod:`rlchain.envs.vecenv`), so a
config's ``vecenv_type: name`` (or the ``vecenv_type`` of its ``env_configurations`` entry, as Isaac Lab
registers ``rlgpu``) trains on it. As in rl_games, registering a name again replaces it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rlchain.envs import vecenv as _vecenv
from rlchain.registry import ENVS, VECENVS
from rlchain.rl_games.common.ivecenv import IVecEnv

vecenv_config = VECENVS
"""rl_games' ``vecenv_config``: name -> creator (rlchain's ``vecenv_type`` registry)."""


def register(config_name: str, func: Callable[..., Any]) -> None:
    """Make ``vecenv_type: config_name`` build envs with ``func(config_name, num_actors, **env_config)``."""
    _vecenv.register(config_name, func, overwrite=True)


def create_vec_env(config_name: str, num_actors: int, **kwargs: Any) -> Any:
    """The vector env of the ``env_configurations`` entry ``config_name``, built by its ``vecenv_type``'s
    creator (what the creator returns, unadapted, as rl_games returns it)."""
    entry = ENVS.get(config_name) if config_name in ENVS else {}
    if "vecenv_type" not in entry:
        raise ValueError(f"vecenv.create_vec_env: '{config_name}' has no env_configurations entry with a "
                         f"'vecenv_type' (register it with env_configurations.register)")
    _, creator = _vecenv.resolve_vecenv_type(entry["vecenv_type"], config_name)
    return creator(config_name, num_actors, **kwargs)


__all__ = ["IVecEnv", "register", "create_vec_env", "vecenv_config"]
