"""OpenAI gym (0.2x) spaces as gymnasium spaces: the one place rlchain accepts the old package's spaces.

rl_games type-checks spaces against ``gym.spaces`` and Isaac Lab's rl_games wrapper hands it
``gym.spaces.Box`` (OpenAI gym 0.26, installed beside gymnasium). Everything in rlchain reads gymnasium
spaces, so an env's spaces pass through :func:`to_gymnasium` where they enter (the IVecEnv adapter,
``get_env_info``, the player and the model builder). ``gym`` itself is never imported: a space is recognised
by its class's module, so this works whether or not gym is installed.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np


class SpaceError(TypeError):
    """A space that is neither a gymnasium space nor a gym space rlchain converts."""


def _gym_class(space: Any) -> str | None:
    """The class name of an OpenAI gym space (``gym.spaces.*``), else None."""
    module = type(space).__module__ or ""
    return type(space).__name__ if module == "gym.spaces" or module.startswith("gym.spaces.") else None


def _where(space: Any) -> str:
    return f"{type(space).__module__}.{type(space).__name__}"


def to_gymnasium(space: Any, strict: bool = True) -> Any:
    """``space`` as a gymnasium space: a gymnasium space as it is, a gym 0.2x Box, Discrete, MultiDiscrete,
    MultiBinary, Tuple or Dict converted (nested ones too); None stays None. Another gym space is a SpaceError
    naming its module and class, and so is any other object when ``strict`` (else it is returned as it is,
    for the caller's own checks)."""
    if space is None or isinstance(space, gymnasium.spaces.Space):
        return space
    name = _gym_class(space)
    if name is None and not strict:
        return space
    if name == "Box":
        return gymnasium.spaces.Box(np.asarray(space.low), np.asarray(space.high), tuple(space.shape),
                                    dtype=space.dtype)
    if name == "Discrete":
        return gymnasium.spaces.Discrete(int(space.n), start=int(getattr(space, "start", 0)))
    if name == "MultiDiscrete":
        return gymnasium.spaces.MultiDiscrete(np.asarray(space.nvec), dtype=space.dtype)
    if name == "MultiBinary":
        return gymnasium.spaces.MultiBinary(space.n)
    if name == "Tuple":
        return gymnasium.spaces.Tuple(tuple(to_gymnasium(s) for s in space.spaces))
    if name == "Dict":
        return gymnasium.spaces.Dict({key: to_gymnasium(s) for key, s in space.spaces.items()})
    raise SpaceError(f"space {space!r} ({_where(space)}) is not supported: expected a gymnasium space or a gym "
                     f"Box, Discrete, MultiDiscrete, MultiBinary, Tuple or Dict")


def spaces_to_gymnasium(info: dict[str, Any]) -> dict[str, Any]:
    """An rl_games env-info dict with its ``*_space`` entries converted by :func:`to_gymnasium`."""
    return {key: to_gymnasium(value) if key.endswith("_space") else value for key, value in info.items()}


__all__ = ["SpaceError", "spaces_to_gymnasium", "to_gymnasium"]
