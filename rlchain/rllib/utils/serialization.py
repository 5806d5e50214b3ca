"""``ray.rllib.utils.serialization``: ``gym_space_to_dict`` / ``gym_space_from_dict``, a gymnasium space as plain
data (RLlib's format: ``{"space": "box", "low": <b64>, "high": <b64>, "shape": (..), "dtype": "<f4"}``; arrays
are ``numpy.save`` bytes, zlib-compressed, base64 text). The arrays are written and read without pickle.
"""

from __future__ import annotations

import base64
import io
import zlib
from typing import Any

import gymnasium as gym
import numpy as np


def _array_text(array: np.ndarray) -> str:
    buf = io.BytesIO()
    np.save(buf, np.asarray(array), allow_pickle=False)
    return base64.b64encode(zlib.compress(buf.getvalue())).decode("ascii")


def _text_array(text: str) -> np.ndarray:
    # the .npy reader itself, object arrays (pickles) refused: the text is data from a file
    return np.lib.format.read_array(io.BytesIO(zlib.decompress(base64.b64decode(text))), allow_pickle=False)


def gym_space_to_dict(space: gym.spaces.Space | None) -> dict[str, Any] | None:
    """``space`` as RLlib's serialized dict (Box, Discrete, MultiBinary, MultiDiscrete, Tuple, Dict, Text)."""
    if space is None:
        return None
    if isinstance(space, gym.spaces.Box):
        return {"space": "box", "low": _array_text(space.low), "high": _array_text(space.high),
                "shape": tuple(space.shape), "dtype": space.dtype.str}
    if isinstance(space, gym.spaces.Discrete):
        return {"space": "discrete", "n": int(space.n), "start": int(space.start)}
    if isinstance(space, gym.spaces.MultiBinary):
        return {"space": "multi-binary", "n": space.n}
    if isinstance(space, gym.spaces.MultiDiscrete):
        return {"space": "multi-discrete", "nvec": _array_text(space.nvec), "dtype": space.dtype.str}
    if isinstance(space, gym.spaces.Tuple):
        return {"space": "tuple", "spaces": [gym_space_to_dict(s) for s in space.spaces]}
    if isinstance(space, gym.spaces.Dict):
        return {"space": "dict", "spaces": {k: gym_space_to_dict(s) for k, s in space.spaces.items()}}
    if isinstance(space, gym.spaces.Text):
        return {"space": "text", "min_length": space.min_length, "max_length": space.max_length,
                "charset": space.character_set}
    raise ValueError(f"gym_space_to_dict: {type(space).__name__} spaces are not serialized by rlchain's RLlib face "
                     f"(Box, Discrete, MultiBinary, MultiDiscrete, Tuple, Dict, Text)")


def gym_space_from_dict(d: dict[str, Any] | None) -> gym.spaces.Space | None:
    """The space :func:`gym_space_to_dict` wrote."""
    if d is None:
        return None
    kind = d.get("space")
    if kind == "box":
        low, high = _text_array(d["low"]), _text_array(d["high"])
        return gym.spaces.Box(low, high, shape=tuple(d["shape"]), dtype=np.dtype(d["dtype"]))
    if kind == "discrete":
        return gym.spaces.Discrete(int(d["n"]), start=int(d.get("start", 0)))
    if kind == "multi-binary":
        return gym.spaces.MultiBinary(d["n"])
    if kind == "multi-discrete":
        return gym.spaces.MultiDiscrete(_text_array(d["nvec"]), dtype=np.dtype(d["dtype"]))
    if kind == "tuple":
        return gym.spaces.Tuple([gym_space_from_dict(s) for s in d["spaces"]])
    if kind == "dict":
        return gym.spaces.Dict({k: gym_space_from_dict(s) for k, s in d["spaces"].items()})
    if kind == "text":
        return gym.spaces.Text(min_length=d["min_length"], max_length=d["max_length"], charset=d["charset"])
    raise ValueError(f"gym_space_from_dict: space {kind!r} is not one rlchain's RLlib face reads "
                     f"(box, discrete, multi-binary, multi-discrete, tuple, dict, text)")


__all__ = ["gym_space_from_dict", "gym_space_to_dict"]
