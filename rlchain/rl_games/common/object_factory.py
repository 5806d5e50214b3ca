"""rl_games' ``ObjectFactory``: name -> builder, as ``Runner.algo_factory`` / ``player_factory`` hold them."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


class ObjectFactory:
    """Builders by name: ``register_builder(name, builder)``, ``create(name, **kwargs)``."""

    def __init__(self) -> None:
        self._builders: dict[str, Callable[..., Any]] = {}

    def register_builder(self, name: str, builder: Callable[..., Any]) -> None:
        """Make ``create(name, **kwargs)`` return ``builder(**kwargs)`` (a name registered again is replaced)."""
        self._builders[name] = builder

    def set_builders(self, builders: dict[str, Callable[..., Any]]) -> None:
        """Replace every builder."""
        self._builders = builders

    def get(self, name: str) -> Callable[..., Any] | None:
        """The builder of ``name``, or None."""
        return self._builders.get(name)

    def create(self, name: str, **kwargs: Any) -> Any:
        """``builder(**kwargs)`` of ``name``; an unknown name is a ValueError naming it (as in rl_games)."""
        builder = self._builders.get(name)
        if not builder:
            raise ValueError(name)
        return builder(**kwargs)


__all__ = ["ObjectFactory"]
