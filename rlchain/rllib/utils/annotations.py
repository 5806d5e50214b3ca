"""``ray.rllib.utils.annotations``: RLlib's decorators, which only mark a method (they change nothing)."""

from __future__ import annotations

from typing import Any


def override(parent: Any) -> Any:
    """``@override(Base)``: marks a method as overriding ``Base``'s."""
    return lambda method: method


def _mark(obj: Any = None, *args: Any, **kwargs: Any) -> Any:
    if obj is None or not callable(obj) or args or kwargs:
        return lambda inner: inner
    return obj


OverrideToImplementCustomLogic = _mark
OverrideToImplementCustomLogic_CallToSuperRecommended = _mark
PublicAPI = _mark
DeveloperAPI = _mark
ExperimentalAPI = _mark
OldAPIStack = _mark

__all__ = ["DeveloperAPI", "ExperimentalAPI", "OldAPIStack", "OverrideToImplementCustomLogic",
           "OverrideToImplementCustomLogic_CallToSuperRecommended", "PublicAPI", "override"]
