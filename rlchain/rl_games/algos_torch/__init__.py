"""rl_games' ``rl_games.algos_torch``: model and network registration, torch helpers, players."""

from typing import Any

from rlchain.rl_games.agents import package_getattr


def __getattr__(name: str) -> Any:
    return package_getattr("rl_games.algos_torch", name)
