"""Which torch device a run uses: ``params.config.device`` resolved once, with a CPU fallback.

rl_games' default device is ``cuda:0`` and most of its YAMLs say nothing, so on a machine without a GPU
:func:`on_available_device` rewrites the config to ``cpu`` once, at load, before anything reads it: the thread
plan, pinned memory, CUDA graphs, mixed precision and a tensor env's ``env_config.device`` then all see the
device the run really uses, and the run is the same run as one whose YAML says ``device: cpu``.
"""

from __future__ import annotations

import warnings

import torch

from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.config.resolve import with_config


def resolve_device(name: str) -> torch.device:
    """``cpu`` / ``cuda`` / ``cuda:N``; without CUDA a cuda device falls back to cpu with a warning."""
    if name.startswith("cuda") and not torch.cuda.is_available():
        warnings.warn(f"params.config.device is '{name}' but CUDA is not available; training on cpu",
                      stacklevel=2)
        return torch.device("cpu")
    try:
        return torch.device(name)
    except RuntimeError:
        raise ConfigError("", "params.config.device", f"'{name}' is not a device (cpu, cuda, cuda:N)") from None


def wants_cuda(name: object) -> bool:
    """Whether a device string names CUDA (``cuda``, ``cuda:N``)."""
    return str(name).strip().lower().startswith("cuda")


def on_available_device(params: Params, cuda_available: bool | None = None) -> Params:
    """``params`` with ``config.device`` (and a CUDA ``env_config.device``) set to ``cpu`` when they ask for
    CUDA and ``cuda_available`` (default: ``torch.cuda.is_available()``) is false; one warning says so.
    Unchanged otherwise (the argument is never modified)."""
    cfg = params.config
    env_device = cfg.env_config.get("device") if isinstance(cfg.env_config, dict) else None
    if not (wants_cuda(cfg.device) or wants_cuda(env_device)):
        return params
    if cuda_available is None:
        cuda_available = torch.cuda.is_available()
    if cuda_available:
        return params
    changes: dict = {}
    if wants_cuda(cfg.device):
        changes["device"] = "cpu"
    if wants_cuda(env_device):
        changes["env_config"] = {**cfg.env_config, "device": "cpu"}
    asked = cfg.device if wants_cuda(cfg.device) else env_device
    where = f"{params.source}: " if params.source else ""
    warnings.warn(f"{where}params.config.device is '{asked}' but CUDA is not available; training on cpu "
                  f"(the same run as with device: cpu)", stacklevel=3)
    return with_config(params, **changes)
