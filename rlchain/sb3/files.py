"""The file of an SB3-style model (``PPO.save`` / ``load`` / ``set_parameters``), read and written as data.

The spaces and constructor arguments are stored as plain values (numbers, strings, lists, tensors), never
as pickled objects, so the file loads through :mod:`rlchain.runs.checkpoint` like every other checkpoint:
a file naming any other object is refused in one line unless the caller trusts it
(``rlchain.runs.checkpoint.trusting()``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from rlchain.sb3.model_zip import has_model, read_model
from rlchain.sb3.zip_format import count, is_sb3_archive, read_sb3_archive

FORMAT = "rlchain-sb3-1"
SPACE = "__space__"


def encode_space(space: gym.Space) -> dict[str, Any]:
    """``space`` as plain data (Box, Discrete, MultiDiscrete, MultiBinary, Dict, Tuple)."""
    if isinstance(space, gym.spaces.Box):
        return {SPACE: "Box", "low": torch.as_tensor(space.low), "high": torch.as_tensor(space.high),
                "dtype": str(space.dtype)}
    if isinstance(space, gym.spaces.Discrete):
        return {SPACE: "Discrete", "n": int(space.n), "start": int(space.start)}
    if isinstance(space, gym.spaces.MultiDiscrete):
        return {SPACE: "MultiDiscrete", "nvec": torch.as_tensor(space.nvec), "dtype": str(space.dtype)}
    if isinstance(space, gym.spaces.MultiBinary):
        return {SPACE: "MultiBinary", "n": list(np.atleast_1d(space.n).tolist())}
    if isinstance(space, gym.spaces.Dict):
        return {SPACE: "Dict", "spaces": {k: encode_space(s) for k, s in space.spaces.items()}}
    if isinstance(space, gym.spaces.Tuple):
        return {SPACE: "Tuple", "spaces": [encode_space(s) for s in space.spaces]}
    raise ValueError(f"cannot save a {type(space).__name__} space (Box, Discrete, MultiDiscrete, MultiBinary, "
                     f"Dict, Tuple)")


def decode_space(data: Any, path: str) -> gym.Space:
    """:func:`encode_space` undone; anything else is a one-line CheckpointError naming ``path``."""
    if isinstance(data, gym.Space):  # a file from before this format, read under trusting()
        return data
    kind = data.get(SPACE) if isinstance(data, dict) else None
    try:
        if kind == "Box":
            return gym.spaces.Box(data["low"].numpy(), data["high"].numpy(), dtype=np.dtype(data["dtype"]))
        if kind == "Discrete":
            return gym.spaces.Discrete(int(data["n"]), start=int(data["start"]))
        if kind == "MultiDiscrete":
            return gym.spaces.MultiDiscrete(data["nvec"].numpy(), dtype=np.dtype(data["dtype"]))
        if kind == "MultiBinary":
            n = data["n"]
            return gym.spaces.MultiBinary(n[0] if len(n) == 1 else n)
        if kind == "Dict":
            return gym.spaces.Dict({k: decode_space(s, path) for k, s in data["spaces"].items()})
        if kind == "Tuple":
            return gym.spaces.Tuple([decode_space(s, path) for s in data["spaces"]])
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ckpt.CheckpointError(f"{path}: a stored {kind} space is malformed ({type(exc).__name__}: "
                                   f"{' '.join(str(exc).split())[:120]})") from None
    raise ckpt.CheckpointError(f"{path}: not a stored space: {str(kind or type(data).__name__)[:60]}")


ACTIVATION = "__torch_activation__"


def encode_value(value: Any) -> Any:
    """``value`` (policy_kwargs, hyperparameters) with torch's activation classes (SB3's
    ``activation_fn=nn.ReLU``) stored by name; other values as they are."""
    if isinstance(value, type) and issubclass(value, torch.nn.Module) \
            and value.__module__ == torch.nn.modules.activation.__name__:
        return {ACTIVATION: value.__name__}
    if isinstance(value, dict):
        return {k: encode_value(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(encode_value(v) for v in value)
    return value


def decode_value(value: Any, path: str) -> Any:
    """:func:`encode_value` undone: a stored name is looked up among torch's activation classes only."""
    if isinstance(value, dict) and set(value) == {ACTIVATION}:
        module = torch.nn.modules.activation
        cls = getattr(module, str(value[ACTIVATION]), None)
        if not (isinstance(cls, type) and issubclass(cls, torch.nn.Module) and cls.__module__ == module.__name__):
            raise ckpt.CheckpointError(f"{path}: '{str(value[ACTIVATION])[:60]}' is not a torch activation")
        return cls
    if isinstance(value, dict):
        return {k: decode_value(v, path) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(decode_value(v, path) for v in value)
    return value


def save_model(state: dict[str, Any], spaces: tuple[gym.Space, gym.Space], path: str) -> None:
    """Write ``state`` (plain values and the policy's state_dict) and ``spaces`` atomically, with checksums."""
    state = {**state, "policy_kwargs": encode_value(state.get("policy_kwargs")),
             "hyperparameters": encode_value(state.get("hyperparameters"))}
    ckpt.save_atomic({**state, "format": FORMAT, "spaces": [encode_space(s) for s in spaces]}, path)


def load_model(path: str, algo: str) -> dict[str, Any]:
    """The state :func:`save_model` wrote, its spaces rebuilt; a file of another kind or algorithm, or one
    naming code, is a one-line error."""
    state = ckpt.read(path)
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise ckpt.CheckpointError(f"{path}: not a model saved by rlchain.{algo.upper()}.save (for a training "
                                   f"checkpoint use rlchain.Runner or `rlchain play`)")
    if state.get("algo") != algo:
        other = str(state.get("algo")).upper()
        raise ckpt.CheckpointError(f"{path}: a {other} model; load it with rlchain.{other}")
    spaces = state.get("spaces")
    if not isinstance(spaces, (list, tuple)) or len(spaces) != 2:
        raise ckpt.CheckpointError(f"{path}: no observation and action spaces stored")
    for key, low, high, default in (("num_timesteps", 0, 2**62, 0), ("n_envs", 1, 1 << 16, 1),
                                    ("seed", -(2**63), 2**63 - 1, None)):
        state[key] = count(state.get(key), path, key, low, high, default)
    if not isinstance(state.get("env_id"), (str, type(None))):
        raise ckpt.CheckpointError(f"{path}: env_id: expected a gymnasium id or nothing, got "
                                   f"{type(state.get('env_id')).__name__}")
    state.setdefault("env_id", None)
    return {**state, "spaces": tuple(decode_space(s, path) for s in spaces),
            "policy_kwargs": decode_value(state.get("policy_kwargs"), path),
            "hyperparameters": decode_value(state.get("hyperparameters"), path)}


def load_weights(path: str) -> dict[str, torch.Tensor]:
    """The policy weights of a file :func:`save_model` (or a training run: ``nn/*.pth``) wrote, as data."""
    state = ckpt.read(path)
    weights = state.get("model") if isinstance(state, dict) else None
    if not isinstance(weights, dict):
        raise ckpt.CheckpointError(f"{path}: holds no 'model' weights (a file written by rlchain's save or a run)")
    return weights


def read_weights(path: str, algo: str) -> dict[str, torch.Tensor]:
    """The policy weights of ``path`` for ``set_parameters``: rlchain's model zip, SB3's own archive of ``algo``
    (SB3's names, read as data by :mod:`rlchain.sb3.zip_format`) or a file :func:`save_model` or a run wrote."""
    if has_model(path):
        return read_model(path, load_weights)
    if is_sb3_archive(path):
        return read_sb3_archive(path, algo).policy_state
    return load_weights(path)


def load_into(policy: torch.nn.Module, weights: dict[str, Any], path: str, what: str, strict: bool = True) -> None:
    """``policy.load_state_dict(weights)``; weights that do not fit are one CheckpointError line naming ``path``
    (torch's own message spans lines)."""
    try:
        policy.load_state_dict(weights, strict=strict)
    except RuntimeError as exc:
        raise ckpt.CheckpointError(f"{path}: its weights do not fit {what} ({' '.join(str(exc).split())[:200]})") \
            from None


@contextlib.contextmanager
def named_by(path: str) -> Iterator[None]:
    """A config error while a loaded file's values (or the caller's keywords beside them) build the model names
    the file, not the model class."""
    try:
        yield
    except ConfigError as exc:
        if exc.source == path:
            raise
        raise ConfigError(path, exc.path, exc.message) from None
