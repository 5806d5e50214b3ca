"""glibc's malloc for a training process (``params.malloc``): keep freed memory for the next allocation.

A PPO epoch allocates and frees the same few-MB tensors over and over (a (16,384 x 64) activation is 4 MB).
With glibc's defaults each one above its adaptive mmap threshold, or on top of a heap it trims after every
free, comes back as fresh pages from the kernel: a page fault and a zeroing per 4 KB, then cold caches for
the kernel that reads them, which makes the update's matmuls and activations slower than the same ops on
warm memory (the tensor-env update most of all; envpool runs are bound by the env). ``keep`` raises the mmap
threshold to glibc's maximum (32 MiB) and stops trimming, so freed blocks are reused; memory is not returned to
the OS until the process ends.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import platform

from rlchain.config.errors import ConfigError
from rlchain.log import get_logger

_log = get_logger(__name__)

M_TRIM_THRESHOLD = -1  # glibc's mallopt parameter numbers (malloc.h)
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 32 * 1024 * 1024  # glibc's largest accepted value on 64-bit
TRIM_THRESHOLD = 2**31 - 1  # mallopt takes a C int: keep up to 2 GB of free memory at the heap's top
_applied: set[str] = set()


def _glibc() -> ctypes.CDLL | None:
    """The C library when it is glibc (Linux), else None: musl, macOS and Windows have no mallopt to tune."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    except OSError:
        return None


def tune_malloc(mode: str = "keep") -> bool:
    """Apply ``params.malloc`` to this process (once; later calls are no-ops). True when glibc took the
    settings; False for ``default``, on a C library other than glibc, or when mallopt refused them."""
    if mode != "keep":
        return False
    if _applied:
        return True
    libc = _glibc()
    if libc is None:
        return False
    ok = bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
    if ok:
        _applied.add("keep")
    else:
        _log.warning("params.malloc: keep: glibc's mallopt refused the settings; malloc stays as it was")
    return ok


def available_bytes(device: str) -> int | None:
    """Memory free for new tensors on ``device`` (a CUDA GPU's free memory, else the host's MemAvailable);
    None when it cannot be read."""
    try:
        if str(device).startswith("cuda"):
            import torch  # the GPU's own count

            if not torch.cuda.is_available():
                return available_bytes("cpu")  # the run falls back to the CPU
            return int(torch.cuda.mem_get_info(torch.device(device))[0])
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, RuntimeError, AttributeError):
        return None


def human_bytes(n: float) -> str:
    """1.5 GiB, 512.0 TiB, 12 B."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} PiB"


def check_fits(nbytes: int, device: str, source: str, key: str, what: str) -> None:
    """A ConfigError naming ``key`` when ``what`` (``nbytes``) is more than ``device`` has free: before the
    storage is built, so no allocation fails half-way or swaps the machine to a halt."""
    free = available_bytes(device)
    if free is not None and nbytes > free:
        raise ConfigError(source, key, f"{what} needs {human_bytes(nbytes)} but {device} has "
                                       f"{human_bytes(free)} available; lower it")
