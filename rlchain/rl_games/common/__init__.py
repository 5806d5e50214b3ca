"""rl_games' ``rl_games.common``: vec envs, env configurations, observers, the player base class."""

from typing import Any

from rlchain.rl_games.agents import package_getattr


def __getattr__(name: str) -> Any:
    return package_getattr("rl_games.common", name)
