"""Build a model only when it fits: its parameter count, read from a build on torch's ``meta`` device (shapes,
no storage, no random draws), is checked against the memory free on the host and the target device first.
A size nobody can allocate (``mlp.units: [1000000000000, 64]``) is then one config line, not the allocator's
error after the run folder exists."""

from __future__ import annotations

import itertools
from collections.abc import Callable

import torch

from rlchain.config.errors import ConfigError
from rlchain.parallel.memory import check_fits, human_bytes


def storage_bytes(module: torch.nn.Module) -> tuple[int, int]:
    """(parameter count, bytes of parameters and buffers) of ``module`` (real or meta)."""
    count = sum(p.numel() for p in module.parameters())
    nbytes = sum(t.numel() * t.element_size() for t in itertools.chain(module.parameters(), module.buffers()))
    return count, nbytes


def build_within_memory(build: Callable[[], torch.nn.Module], device: torch.device | str, source: str,
                        key: str = "params.network") -> torch.nn.Module:
    """``build()`` (on the CPU) once its size is known to fit the host and ``device``; a model that does not is
    a ConfigError naming ``key``. A builder that cannot run on the meta device is built without the check."""
    try:
        with torch.device("meta"):
            meta = build()
    except Exception:  # e.g. a builder that reads a value back (.item()): the real build says what it needs
        meta = None
    if meta is not None:
        count, nbytes = storage_bytes(meta)
        what = f"the model ({count:,} parameters)"
        check_fits(nbytes, "cpu", source, key, what)  # built on the host, then moved
        if str(device) != "cpu":
            check_fits(nbytes, str(device), source, key, what)
    try:
        return build()
    except MemoryError:
        raise ConfigError(source, key, "the model does not fit in memory; make the network smaller") from None
    except RuntimeError as exc:
        if "alloc" not in str(exc).lower():
            raise
        size = "" if meta is None else f" ({human_bytes(storage_bytes(meta)[1])})"
        raise ConfigError(source, key, f"the model{size} cannot be allocated: make the network smaller") from None
