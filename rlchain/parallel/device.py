"""Which torch device a run uses: ``params.config.device`` resolved once, with a CPU fallback."""

from __future__ import annotations

import warnings

import torch

from rlchain.config.errors import ConfigError


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
