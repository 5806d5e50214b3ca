"""``ray.rllib.utils.serialization``: ``gym_space_to_dict`` / ``gym_space_from_dict``, a gymnasium space as plain
data (RLlib's format: ``{"space": "box", "low": <b64>, "high": <b64>, "shape": (..), "dtype": "<f4"}``; arrays
are ``numpy.save`` bytes, zlib-compressed, base64 text). The arrays are written and read without pickle.
"""

from __future__ import annotations

import base64
import io
import math
import zlib
from typing import Any

import gymnasium as gym
import numpy as np

NPY_HEADER_BYTES = 65_536 + 12
"""The most an array's ``.npy`` preamble takes before its data (magic, version, length field, header)."""
MAX_ARRAY_BYTES = 256 * 2**20
"""The largest array a serialized space may hold (a space's bounds, not data): a declared shape above it, or an
array without one (``nvec``) that inflates past it, is refused."""


def _array_text(array: np.ndarray) -> str:
    buf = io.BytesIO()
    np.save(buf, np.asarray(array), allow_pickle=False)
    return base64.b64encode(zlib.compress(buf.getvalue())).decode("ascii")


def _fail(key: str, message: str) -> ValueError:
    return ValueError(f"gym_space_from_dict: {key}: {message}")


def _inflate(data: bytes, limit: int, key: str) -> bytes:
    """``data`` decompressed, never more than ``limit`` bytes (a crafted stream cannot expand past it)."""
    inflater = zlib.decompressobj()
    try:
        out = inflater.decompress(data, limit + 1)
    except zlib.error as exc:
        raise _fail(key, f"not zlib-compressed .npy bytes ({exc})") from None
    if len(out) > limit or inflater.unconsumed_tail:
        raise _fail(key, f"the array inflates past {limit} bytes, more than the space declares")
    if not inflater.eof:
        raise _fail(key, "the compressed array is cut short")
    return out


def _text_array(text: Any, key: str, shape: Any = None, dtype: Any = None) -> np.ndarray:
    """The array of ``key`` (base64 text of zlib-compressed ``.npy`` bytes), inflated no further than the space's
    declared ``shape`` and ``dtype`` allow (:data:`MAX_ARRAY_BYTES` where none is declared); the ``.npy`` reader
    itself, object arrays (pickles) refused: the text is data from a file."""
    if not isinstance(text, (str, bytes)):
        raise _fail(key, f"expected base64 text, got {type(text).__name__}")
    declared = MAX_ARRAY_BYTES if shape is None else math.prod(shape) * dtype.itemsize
    if declared > MAX_ARRAY_BYTES:
        raise _fail(key, f"the declared shape {tuple(shape)} of {dtype} takes {declared} bytes, over the "
                         f"{MAX_ARRAY_BYTES} a space's bounds may take")
    try:
        raw = base64.b64decode(text)
    except ValueError as exc:
        raise _fail(key, f"not base64 text ({exc})") from None
    buf = io.BytesIO(_inflate(raw, declared + NPY_HEADER_BYTES, key))
    try:
        version = np.lib.format.read_magic(buf)
        read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) \
            else np.lib.format.read_array_header_2_0
        stored_shape, _, stored_dtype = read_header(buf)
    except ValueError as exc:
        raise _fail(key, f"not .npy bytes ({exc})") from None
    if math.prod(stored_shape) * stored_dtype.itemsize > declared:  # before the reader allocates for it
        raise _fail(key, f"the stored array {stored_shape} of {stored_dtype} is larger than the space declares")
    buf.seek(0)
    try:
        return np.lib.format.read_array(buf, allow_pickle=False)
    except ValueError as exc:
        raise _fail(key, str(exc).splitlines()[0] if str(exc) else "unreadable array") from None


def _shape_dtype(d: dict[str, Any], key: str) -> tuple[tuple[int, ...], np.dtype]:
    shape, dtype = d.get("shape"), d.get("dtype")
    if not isinstance(shape, (list, tuple)) or not all(isinstance(n, int) and not isinstance(n, bool) and n >= 0
                                                        for n in shape):
        raise _fail(f"{key}shape", f"expected a list of whole numbers >= 0, got {shape!r}")
    try:
        return tuple(shape), np.dtype(dtype)
    except TypeError as exc:
        raise _fail(f"{key}dtype", f"not a numpy dtype ({exc})") from None


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
    """The space :func:`gym_space_to_dict` wrote (its arrays read as bounded data: :func:`_text_array`)."""
    return _space_from_dict(d, "")


def _space_from_dict(d: Any, where: str) -> gym.spaces.Space | None:
    if d is None:
        return None
    if not isinstance(d, dict):
        raise _fail(where.rstrip(".") or "space", f"expected a dict, got {type(d).__name__}")
    kind = d.get("space")
    if kind == "box":
        shape, dtype = _shape_dtype(d, where)
        low = _text_array(d.get("low"), f"{where}low", shape, dtype)
        high = _text_array(d.get("high"), f"{where}high", shape, dtype)
        return gym.spaces.Box(low, high, shape=shape, dtype=dtype)
    if kind == "discrete":
        return gym.spaces.Discrete(int(d["n"]), start=int(d.get("start", 0)))
    if kind == "multi-binary":
        return gym.spaces.MultiBinary(d["n"])
    if kind == "multi-discrete":
        try:
            dtype = np.dtype(d.get("dtype"))
        except TypeError as exc:
            raise _fail(f"{where}dtype", f"not a numpy dtype ({exc})") from None
        return gym.spaces.MultiDiscrete(_text_array(d.get("nvec"), f"{where}nvec"), dtype=dtype)
    if kind == "tuple":
        return gym.spaces.Tuple([_space_from_dict(s, f"{where}spaces.{i}.") for i, s in enumerate(d["spaces"])])
    if kind == "dict":
        return gym.spaces.Dict({k: _space_from_dict(s, f"{where}spaces.{k}.") for k, s in d["spaces"].items()})
    if kind == "text":
        return gym.spaces.Text(min_length=d["min_length"], max_length=d["max_length"], charset=d["charset"])
    raise ValueError(f"gym_space_from_dict: space {kind!r} is not one rlchain's RLlib face reads "
                     f"(box, discrete, multi-binary, multi-discrete, tuple, dict, text)")


__all__ = ["gym_space_from_dict", "gym_space_to_dict"]
