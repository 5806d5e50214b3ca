"""``mixed_precision`` resolved for one device: the dtype the update's forward passes autocast to."""

from __future__ import annotations

from typing import Any

import torch

from rlchain.config.run import amp_dtype_name
from rlchain.log import get_logger

_log = get_logger(__name__)
_warned: set[str] = set()


def cpu_has_bf16() -> bool:
    """True where this CPU multiplies bfloat16 natively (AVX512-BF16 or AMX, through oneDNN); elsewhere
    torch emulates it and bf16 is slower than float32."""
    try:
        return bool(torch.backends.mkldnn.is_available() and torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):  # a torch build without oneDNN
        return False


def autocast_dtype(value: Any, device: torch.device, bf16_cpu: bool | None = None) -> torch.dtype | None:
    """The autocast dtype of the PPO update under ``mixed_precision: value`` on ``device``; None = float32.

    On CUDA: True / bf16 = bfloat16 (float16 on a GPU without bf16), fp16 = float16, as rl_games does.
    On a CPU only ``bf16``, asked for by name, turns it on, and only where the CPU has native bf16
    (``bf16_cpu``, default :func:`cpu_has_bf16`): rl_games YAMLs carry ``mixed_precision: True`` for
    their GPUs and run float32 on a CPU, as they do in rl_games. Elsewhere one warning, and float32.
    """
    if device.type == "cuda":
        name = amp_dtype_name(value, torch.cuda.is_bf16_supported())
        return getattr(torch, name) if name is not None else None
    if device.type != "cpu" or value != "bf16":
        return None
    if cpu_has_bf16() if bf16_cpu is None else bf16_cpu:
        return torch.bfloat16
    if "cpu" not in _warned:
        _warned.add("cpu")
        _log.warning("mixed_precision: bf16 asks for bfloat16, but this CPU has no native bf16 (AVX512-BF16 "
                     "or AMX): the update runs in float32")
    return None


def sac_autocast_dtype(value: Any, device: torch.device) -> torch.dtype | None:
    """SAC's ``mixed_precision`` (rl_games 2.0): bfloat16 autocast of the critic and actor updates on a CUDA GPU
    with bf16, no grad scaler; elsewhere (a CPU, a GPU without bf16) one warning and float32."""
    if not value:
        return None
    if device.type == "cuda" and torch.cuda.is_bf16_supported():
        return torch.bfloat16
    if "sac" not in _warned:
        _warned.add("sac")
        where = "a CPU" if device.type != "cuda" else "this GPU (no bf16)"
        _log.warning(f"mixed_precision: SAC autocasts to bfloat16 on CUDA GPUs only; on {where} it runs in float32")
    return None
