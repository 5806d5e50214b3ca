"""Checksums of the tensors a checkpoint stores, so a flipped bit on disk or in a copy is an error naming
the tensor instead of weights that load and silently act differently.

The digest is for corruption, not for trust (a file's author can write any digest): what a file may
contain is :mod:`rlchain.runs.checkpoint`'s allow-list.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterator
from typing import Any

import torch

ALGORITHM = "crc32"
KEY = "checksums"
"""The checkpoint key holding ``{"algorithm": ALGORITHM, "tensors": {path: checksum}}``."""


def tensors(value: Any, path: str = "") -> Iterator[tuple[str, torch.Tensor]]:
    """Every tensor in nested dicts / lists / tuples, with its dotted path (``model.actor.0.weight``)."""
    if isinstance(value, torch.Tensor):
        yield path, value
    elif isinstance(value, dict):
        for key, item in value.items():
            if path == "" and key == KEY:
                continue
            yield from tensors(item, f"{path}.{key}" if path else str(key))
    elif isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            yield from tensors(item, f"{path}.{i}" if path else str(i))


def checksum(tensor: torch.Tensor) -> int:
    """CRC-32 of the tensor's values as stored (its bytes, any dtype, any device)."""
    flat = tensor.detach().reshape(-1)
    if flat.device.type != "cpu":
        flat = flat.cpu()
    if flat.numel() == 0:
        return 0
    raw = flat.contiguous().view(torch.uint8) if flat.dtype != torch.uint8 else flat.contiguous()
    return zlib.crc32(raw.numpy())


def digest(state: dict[str, Any]) -> dict[str, Any]:
    """The checksum entry of ``state``: one checksum per tensor, by path."""
    return {"algorithm": ALGORITHM, "tensors": {path: checksum(t) for path, t in tensors(state)}}


def first_mismatch(state: dict[str, Any]) -> str | None:
    """The path of the first tensor whose checksum differs from the one stored (or that is missing), else
    None; a state without checksums (an older checkpoint) or with another algorithm is not checked."""
    stored = state.get(KEY)
    if not isinstance(stored, dict) or stored.get("algorithm") != ALGORITHM:
        return None
    found = dict(tensors(state))
    for path, expected in stored.get("tensors", {}).items():
        tensor = found.get(path)
        if tensor is None:
            return f"{path} (missing)"
        if checksum(tensor) != expected:
            return path
    return None
