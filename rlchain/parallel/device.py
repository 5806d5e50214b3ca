"""Where a config runs: a CUDA device that this machine lacks becomes ``cpu`` once, at load.

rl_games' default device is ``cuda:0`` and most of its YAMLs say nothing, so on a machine without a GPU
the config is rewritten to ``cpu`` before anything reads it: the thread plan, pinned memory, CUDA graphs,
mixed precision and a tensor env's ``env_config.device`` then all see the device the run really uses, and
the run is the same run as one whose YAML says ``device: cpu``.
"""

from __future__ import annotations

import warnings

import torch

from rlchain.config.resolve import with_config
from rlchain.config.schema import Params


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
