"""rl_games' ``rl_games.common.env_configurations``: ``register(name, config)`` and ``configurations``.

``register`` is :func:`rlchain.env_configurations.register` (the entry goes to rlchain's env registry;
an ``env_creator`` is also registered with gymnasium), except that, as in rl_games, a name registered
again is replaced. An entry with a ``vecenv_type`` (Isaac Lab: ``{'vecenv_type': 'IsaacRlgWrapper',
'env_creator': lambda **kw: env}``) trains through that vector env when ``params.config.env_name`` names it.
"""

from __future__ import annotations

from typing import Any

from rlchain import env_configurations as _env_configurations
from rlchain.envs.gym_spaces import spaces_to_gymnasium

configurations = _env_configurations.configurations
"""name -> the dict given to :func:`register` (rl_games' ``configurations``; rlchain's ``registry.ENVS``)."""


def register(name: str, config: dict[str, Any]) -> None:
    """Register ``config`` (``env_creator``, ``vecenv_creator`` and / or ``vecenv_type``) under ``name``,
    replacing any entry."""
    _env_configurations.register(name, config, overwrite=True)


def get_env_info(env: Any) -> dict[str, Any]:
    """``observation_space``, ``action_space``, ``agents``, ``value_size`` (and ``state_space`` when the
    env has one) of an env: its ``get_env_info()`` when it has one, else its attributes; OpenAI gym spaces
    come back as gymnasium ones."""
    info = dict(env.get_env_info() or {}) if callable(getattr(env, "get_env_info", None)) else {}
    for key in ("observation_space", "action_space"):
        if key not in info:
            info[key] = getattr(env, key)
    if "agents" not in info:
        agents = getattr(env, "get_number_of_agents", None)
        info["agents"] = agents() if callable(agents) else 1
    if "value_size" not in info:
        info["value_size"] = getattr(env, "value_size", 1)
    return spaces_to_gymnasium(info)


__all__ = ["configurations", "register", "get_env_info"]
